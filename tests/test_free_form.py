"""Questions without lettered options: answered in words and marked free_form (services/agent/free_form.py).

The offline rule reads the camera-motion sentence about the asked pair; a model (the scripted local
server, the one stand-in) is asked with the free-form prompts and its words are kept; and a solve
over real services says `answer_format: free_form`.
"""

from __future__ import annotations

import json
from collections.abc import Iterator

import httpx
import pytest

from services.agent import free_form
from services.agent.answering import answer_from_images, answer_offline, answer_with_model, read_model_answer
from services.agent.llm import ChatClient, ChatModelConfig
from shared.local.services import running_service
from shared.questions.intent import parse_question
from tests.support.scenes import orbit_views
from tests.support.scripted_llm import ScriptedLLM
from tests.support.stack import recon_env, upload_posed_views

CLUE = (
    "From view 1 to view 2 the camera moved right without turning significantly. "
    "From view 2 to view 3 the camera moved diagonally forward and right and turned left by about 45 degrees."
)


def test_the_format_follows_the_options():
    assert free_form.answer_format(parse_question("Which way did I move? A. Left B. Right", 2)) == "choice"
    assert (
        free_form.answer_format(parse_question("Which way did I move from view 1 to view 2?", 2))
        == "free_form"
    )


@pytest.mark.parametrize(
    ("question", "words"),
    [
        (
            "Which way did the camera move from view 1 to view 2?",
            "moved right, without turning significantly",
        ),
        (
            "Which way did the camera move from view 2 to view 3?",
            "moved diagonally forward and right, turned left by about 45 degrees",
        ),
        ("How did the camera turn from view 2 to view 3?", "turned left by about 45 degrees"),
        ("How did the camera turn from view 1 to view 2?", "did not turn significantly"),
    ],
)
def test_offline_the_motion_sentence_of_the_asked_pair_in_its_words(question, words):
    result = answer_offline(parse_question(question, 3), CLUE, [])
    assert result.answer == words and result.method == "offline_text"
    assert "The program's output says" in result.reasoning


def test_offline_says_why_when_the_words_cannot_answer():
    motion = parse_question("Which way did the camera move from view 1 to view 2?", 3)
    down = answer_offline(
        motion, "From view 1 to view 2 the camera moved down without turning significantly.", []
    )
    assert down.answer == "moved down, without turning significantly"  # up and down are words too now
    nothing = answer_offline(motion, "From view 1 to view 2 the camera moved.", [])
    assert nothing.answer is None and "finds no direction" in nothing.reason
    assert (
        "no sentence about view 1 to view 2"
        in answer_offline(motion, "From view 2 to view 3 the camera moved left.", []).reason
    )
    assert "vision model" in answer_offline(motion, None, [b"png"]).reason
    behind = answer_offline(parse_question("From image 1, what is behind me?", 3), CLUE, [])
    assert behind.answer is None and "motion sentence does not answer" in behind.reason


def test_a_model_reply_is_read_as_words():
    assert read_model_answer('{"reasoning": "r", "answer": "to the left"}', {}).answer == "to the left"
    assert read_model_answer("It went to the left.", {}).method == "model_free_text"
    empty = read_model_answer('{"reasoning": "cannot tell", "answer": ""}', {})
    assert empty.answer is None and "empty answer" in empty.reason


@pytest.fixture()
def client(llm: ScriptedLLM) -> Iterator[ChatClient]:
    llm.reset()
    config = ChatModelConfig(base_url=llm.base_url, model="viewer", timeout_s=5, max_retries=0)
    with ChatClient(config) as chat:
        yield chat


def test_the_answer_model_is_asked_for_words_not_a_letter(llm: ScriptedLLM, client: ChatClient):
    intent = parse_question("Which way did the camera move from view 1 to view 2?", 2)
    llm.script([json.dumps({"reasoning": "The sofa shifts left.", "answer": "to the right"})] * 2)
    result = answer_with_model(client, intent, [b"png-1", b"png-2"], "def program(s): ...", CLUE, [])
    assert result.answer == "to the right" and result.method == "model_json"
    result = answer_from_images(client, intent, [b"png-1", b"png-2"])
    assert result.answer == "to the right"
    # The images-only path counts its tokens like the others (the server's usage, words here).
    assert result.prompt_tokens > 0 and result.completion_tokens > 0
    for request in llm.requests():
        prompt = " ".join(part.get("text", "") for part in request["messages"][0]["content"])
        assert "in a few words" in prompt and "one letter" not in prompt
        assert "enum" not in json.dumps(request["response_format"])  # any words, no letters


@pytest.fixture(scope="module")
def agent(tmp_path_factory, redis_url):
    with running_service(
        "services.recon.app:create_app", recon_env(tmp_path_factory.mktemp("r"), redis_url)
    ) as r:
        env = {"PYSPATIAL_RECON_URL": r.url, "PYSPATIAL_CODE_MODEL": "", "PYSPATIAL_ANSWER_MODEL": ""}
        with running_service("services.agent.app:create_app", env) as service:
            service.scene_id = upload_posed_views(r.url, orbit_views(seed=7, num_views=3))
            yield service


def test_a_solve_without_options_answers_in_words_and_says_so(agent):
    body = {"question": "Which way did the camera move from view 1 to view 2?", "scene_id": agent.scene_id}
    result = httpx.post(agent.url + "/v1/solve", json={**body, "backbone": "posed-rgbd"}, timeout=120).json()
    assert "answer_format" in result, result
    assert result["answer_format"] == "free_form" and result["answer_method"] == "offline_text"
    assert result["answer"].startswith("moved "), result
    assert result["steps"][-1]["answer_format"] == "free_form"
    choice = {**body, "question": body["question"] + " A. Left B. Right C. Forward D. Backward"}
    result = httpx.post(
        agent.url + "/v1/solve", json={**choice, "backbone": "posed-rgbd"}, timeout=120
    ).json()
    assert result["answer_format"] == "choice" and result["answer"] in "ABCD"
