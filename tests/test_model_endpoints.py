"""Real code models as they are, over HTTP: real recon and agent processes, real Redis, real images.

The model is the scripted OpenAI-compatible server, replaying the 43 recorded replies of a real
model, acting as a text-only llama.cpp server, rejecting keys and echoing the Authorization header
as real servers do, or sending replies built to stall a regex.
"""

from __future__ import annotations

import base64
import threading
import time

import httpx
import pytest

from services.agent.program_cleanup import program_fingerprint
from shared.local.services import running_service
from shared.wire.client import AgentClient
from tests.support.model_replies import recorded_replies
from tests.support.scenes import orbit_views
from tests.support.stack import recon_env, upload_posed_views
from tests.test_model_replies import cleaned

RECON_APP = "services.recon.app:create_app"


def png_base64(png: bytes) -> str:
    return base64.b64encode(png).decode()


AGENT_APP = "services.agent.app:create_app"
SECRET = "sk-test-SECRET0123456789abcdef"
MOTION_REPLY = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.describe_camera_motion(recon)
```"""
REPLIES = recorded_replies()
# Recorded programs whose logic is sound: they render what a camera would see after a move.
SOUND = [4, 15, 16, 19, 20, 25, 33, 34]
# Recorded programs that "answer" with text they typed themselves (an option, or their own words).
TYPED_IN = [0, 3, 17, 21, 41]
# Recorded programs that fail, with the error and the hint the repair message gives.
FAILING = {9: ("shapes (4,4) and (3,) not aligned", "camera_center"), 12: ("not iterable", "image handle")}


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=5, num_views=3)


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service(RECON_APP, env) as service:
        yield service


@pytest.fixture(scope="module")
def scene_id(recon, views) -> str:
    return upload_posed_views(recon.url, views)


def _agent_env(recon, llm, **extra: str) -> dict[str, str]:
    return {
        "PYSPATIAL_RECON_URL": recon.url,
        "PYSPATIAL_CODE_MODEL": "coder",
        "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
        "PYSPATIAL_MODEL_TIMEOUT_S": "5",
        "PYSPATIAL_MODEL_MAX_RETRIES": "1",
        "PYSPATIAL_SANDBOX_WALL_S": "10",
        **extra,
    }


@pytest.fixture(scope="module")
def vision_agent(recon, llm):
    """A code model and an answer model that take images, both behind a key."""
    env = _agent_env(
        recon,
        llm,
        PYSPATIAL_CODE_MODEL_API_KEY=SECRET,
        PYSPATIAL_ANSWER_MODEL="answerer",
        PYSPATIAL_ANSWER_MODEL_BASE_URL=llm.base_url,
        PYSPATIAL_ANSWER_MODEL_API_KEY=SECRET,
        PYSPATIAL_MAX_REPLY_CHARS="200000",
    )
    with running_service(AGENT_APP, env) as service:
        yield service


@pytest.fixture(scope="module")
def text_agent(recon, llm):
    """Only a text-only code model (no answer model): the llama.cpp-on-a-laptop set-up."""
    with running_service(AGENT_APP, _agent_env(recon, llm, PYSPATIAL_CODE_MODEL_TEXT_ONLY="true")) as service:
        yield service


def solve(agent, scene_id: str, question: str, max_repairs: int = 0) -> httpx.Response:
    body = {"question": question, "scene_id": scene_id, "backbone": "posed-rgbd", "max_repairs": max_repairs}
    return httpx.post(agent.url + "/v1/solve", json=body, timeout=120)


# ---- text-only endpoints -------------------------------------------------------------------------


def test_a_text_only_server_is_reported_clearly_when_the_setting_is_off(vision_agent, llm, scene_id):
    llm.reset()
    llm.text_only()
    llm.script([MOTION_REPLY], model="coder")
    response = solve(vision_agent, scene_id, "Which way did I move from view 1 to view 2? A. left B. right")
    assert response.status_code == 502, response.text
    detail = response.json()["detail"]
    assert "can only concatenate str" in detail and "PYSPATIAL_CODE_MODEL_TEXT_ONLY=true" in detail
    assert len(llm.requests()) == 1  # detected at once: not retried, no silent offline fallback


def test_a_text_only_server_works_once_the_setting_is_on(text_agent, llm, scene_id, views):
    from tests.test_agent_service import motion_question

    question, truth = motion_question(views)
    llm.reset()
    llm.text_only()
    llm.script([MOTION_REPLY], model="coder")
    with AgentClient(text_agent.url) as agent:
        result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd")
    assert result.code_model == "coder" and result.code_model_fallback is None
    assert result.answer == truth and result.answer_model == "offline-answerer"
    (request,) = llm.requests()
    assert isinstance(request["messages"][0]["content"], str)
    assert "You do not see them" in request["messages"][0]["content"]
    assert result.tokens.code_prompt > 0 and result.tokens.code_completion > 0


def test_a_text_model_answers_a_text_clue_the_offline_rules_cannot_read(text_agent, llm, scene_id):
    question = "Where did I go from view 1 to view 2? A. toward the door B. toward the window"
    llm.reset()
    llm.text_only()
    llm.script(
        [MOTION_REPLY, '{"reasoning": "The output says the camera moved.", "answer": "B"}'], model="coder"
    )
    with AgentClient(text_agent.url) as agent:
        result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd")
    assert result.answer == "B" and result.answer_method == "text_model"
    assert result.answer_model == "coder (text only)" and result.code_model == "coder"
    assert (
        result.reasoning.startswith("Answered by a text-only model")
        and "did not see the photos" in result.reasoning
    )
    answer_request = llm.requests()[1]
    assert isinstance(answer_request["messages"][0]["content"], str)
    assert "view 1 to view 2" in answer_request["messages"][0]["content"]


@pytest.mark.parametrize(
    ("raw", "content_type", "what"),
    [
        ("<html><body>502 Bad Gateway</body></html>", "text/html", "not JSON (text/html"),
        ('{"object": "chat.completion"}', "application/json", "'choices' is missing"),
    ],
)
def test_a_code_model_reply_that_is_no_completion_is_a_502_naming_the_endpoint(
    vision_agent, llm, scene_id, raw, content_type, what
):
    llm.reset()
    llm.script([{"raw_body": raw, "content_type": content_type}], model="coder")
    response = solve(vision_agent, scene_id, "Which way did I move? A. left B. right")
    assert response.status_code == 502, response.text
    detail = response.json()["detail"]
    assert f"model 'coder' at {llm.base_url}" in detail and what in detail
    assert len(llm.requests()) == 1  # a broken endpoint answers the same again: not retried


# ---- keys and secrets ----------------------------------------------------------------------------


def test_a_rejected_key_is_a_502_the_client_sees_without_the_key(vision_agent, llm, scene_id):
    llm.reset()
    llm.script(
        [{"status": 401, "error_message": "Incorrect API key. Header was Authorization: {authorization}"}],
        model="coder",
    )
    response = solve(vision_agent, scene_id, "Which way did I move? A. left B. right")
    assert response.status_code == 502, response.text
    detail = response.json()["detail"]
    assert "rejected the API key (HTTP 401)" in detail and "[redacted]" in detail
    assert SECRET not in response.text and "SECRET0123" not in vision_agent.log()
    assert llm.requests()[0]["body"]["model"] == "coder" and len(llm.requests()) == 1


def test_a_rejected_answer_key_on_the_images_only_path_is_a_502_naming_the_setting(vision_agent, llm, views):
    """Photos the backbone cannot use (posed-rgbd, no depths): no program runs, the answer model
    answers from the photos alone, and its rejected key is the client's 502, not a null answer."""
    llm.reset()
    llm.script([{"status": 401, "error_message": "Incorrect API key {authorization}"}], model="answerer")
    body = {
        "question": "Which way did I move? A. left B. right",
        "images": [png_base64(p) for p in views.pngs()],
    }
    response = httpx.post(vision_agent.url + "/v1/solve", json=body, timeout=120)
    assert response.status_code == 502, response.text
    detail = response.json()["detail"]
    assert "model 'answerer'" in detail and "rejected the API key (HTTP 401)" in detail
    assert "PYSPATIAL_ANSWER_MODEL_API_KEY" in detail and SECRET not in response.text
    assert [request["body"]["model"] for request in llm.requests()] == ["answerer"]  # no code model ran


def test_an_upstream_error_echoing_the_key_never_reaches_the_response_or_the_log(vision_agent, llm, scene_id):
    echo = {"status": 500, "error_message": "upstream crashed handling Authorization: {authorization}"}
    llm.reset()
    llm.script([echo, echo], model="coder")
    with AgentClient(vision_agent.url) as agent:
        result = agent.solve(
            "Which way did I move? A. left B. right", scene_id=scene_id, backbone="posed-rgbd"
        )
    # A transient failure: the offline planner wrote the program, and the response says so and why.
    assert result.code_model.startswith("offline-planner (fallback: coder")
    assert "HTTP 500" in result.code_model_fallback and "[redacted]" in result.code_model_fallback
    assert SECRET not in result.model_dump_json() and "SECRET0123" not in vision_agent.log()
    assert "fallback" in vision_agent.log() or "falling back" in vision_agent.log()


# ---- replies built to stall the parser -----------------------------------------------------------


def _poll_healthz(url: str, stop: threading.Event, failures: list[str]) -> None:
    with httpx.Client(timeout=2.0) as client:
        while not stop.is_set():
            try:
                client.get(url + "/healthz").raise_for_status()
            except httpx.HTTPError as error:
                failures.append(repr(error))
            time.sleep(0.05)


@pytest.mark.parametrize(
    ("reply", "kind"),
    [
        ("```python " * 15_000, "no_program"),  # 150 KB on one line: minutes for the old regex
        ("```python \n" * 14_000, "no_program"),
        ("```python\n" + "def program(input_scene):\n    return 1\n" * 100 + "x" * 210_000, "too_long"),
    ],
    ids=["fence-bomb-one-line", "fence-bomb-lines", "over-the-size-cap"],
)
def test_bomb_replies_fail_cleanly_while_healthz_answers(vision_agent, llm, scene_id, reply, kind):
    llm.reset()
    llm.script([reply], model="coder")
    stop, failures = threading.Event(), []
    poller = threading.Thread(target=_poll_healthz, args=(vision_agent.url, stop, failures))
    poller.start()
    try:
        response = solve(vision_agent, scene_id, "Which way did I move? A. left B. right")
    finally:
        stop.set()
        poller.join()
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["answer"] is None and body["attempts"][0]["error_kind"] == kind
    assert failures == []  # /healthz answered within 2 s every time


# ---- repairs that change something ---------------------------------------------------------------


def test_a_repair_never_resends_an_identical_program(vision_agent, llm, scene_id):
    failing = REPLIES[9]  # np.dot(4x4, 3-vector): fails on every scene
    llm.reset()
    llm.script(
        [failing.script_entry(), REPLIES[10].script_entry(), REPLIES[11].script_entry()], model="coder"
    )
    response = solve(
        vision_agent, scene_id, "Which way did I move from view 1 to view 2? A. left B. right", 2
    )
    body = response.json()
    attempts = body["attempts"]
    # The model's three attempts, then the planner's program (labelled, the model's attempts kept).
    assert [a["error_kind"] for a in attempts] == ["exception", "repeated", "repeated", None]
    assert body["program_source"] == "planner" and attempts[3]["reply"] is None
    attempts = attempts[:3]
    assert "not aligned" in attempts[0]["error"] and "not run again" in attempts[1]["error"]
    assert [a["temperature"] for a in attempts] == sorted(a["temperature"] for a in attempts)
    assert attempts[2]["temperature"] > attempts[0]["temperature"]
    repairs = [request["messages"][-1]["content"] for request in llm.requests()[1:]]
    assert "pySpatial.camera_center" in repairs[0] and "identical to attempt 1" in repairs[1]
    assert body["answer"] is None and body["answer_model"] == "answerer"
    assert body["code_model"] == "offline-planner (fallback: coder failed)"


# ---- the recorded replies on a synthetic scene ---------------------------------------------------


def _unique(indices: list[int]) -> list[int]:
    seen, kept = set(), []
    for index in indices:
        fingerprint = program_fingerprint(cleaned(REPLIES[index].reply)[0])
        if fingerprint not in seen:
            seen.add(fingerprint)
            kept.append(index)
    return kept


def test_recorded_programs_with_sound_logic_run_and_render(text_agent, llm, scene_id):
    question = "Standing where image 1 was taken, what is behind me? A. a sofa B. a lamp"
    with AgentClient(text_agent.url) as agent:
        for index in _unique(SOUND):
            llm.reset()
            llm.script([REPLIES[index].script_entry()], model="coder")
            result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd", max_repairs=0)
            first = result.attempts[0]
            if first.error_kind == "wrong_view":  # rendered from another view than image 1: sent back
                assert "asks from image 1" in first.error and result.program_source == "planner"
                assert "recon.extrinsics[0]" in result.program
            else:
                # It ran and rendered; with no vision answer model here its image-only clue is sent
                # back (unread) and the labelled planner fallback runs (its renders are unread too).
                assert first.error_kind == "unread_images", (index, first.error)
                assert "returned only" in first.error and first.program == cleaned(REPLIES[index].reply)[0]
                assert result.program_source == "planner"
            assert len(result.clue.images) >= 1
            assert result.answer is None and "vision model" in result.answer_reason  # no one can see it


def test_recorded_programs_that_type_the_answer_are_not_evidence(text_agent, llm, scene_id):
    question = (
        "How did I turn from view 1 to view 2? A. did not turn B. turned left by about 90 degrees "
        "C. turned right by about 90 degrees D. turned right by about 45 degrees"
    )
    with AgentClient(text_agent.url) as agent:
        for index in _unique(TYPED_IN):
            llm.reset()
            llm.script([REPLIES[index].script_entry()], model="coder")
            result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd", max_repairs=0)
            attempt, planned = result.attempts  # the model's, then the planner's (labelled)
            assert attempt.error_kind == "not_evidence", (index, attempt.error)
            assert "typed" in attempt.error and planned.reply is None and result.program_source == "planner"


def test_recorded_programs_that_fail_say_why_and_what_to_call(text_agent, llm, scene_id):
    with AgentClient(text_agent.url) as agent:
        for index, (error, hint) in FAILING.items():
            llm.reset()
            llm.script([REPLIES[index].script_entry(), MOTION_REPLY], model="coder")
            result = agent.solve(
                "Which way did I move from view 1 to view 2? A. left B. right",
                scene_id=scene_id,
                backbone="posed-rgbd",
                max_repairs=1,
            )
            assert error in result.attempts[0].error and result.attempts[1].error is None
            assert hint in llm.requests()[1]["messages"][-1]["content"]
