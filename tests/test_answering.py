"""Answering with a (scripted) model and offline from camera-motion text."""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest

from services.agent.answering import answer_offline, answer_with_model, read_model_answer
from services.agent.llm import ChatClient, ChatModelConfig
from shared.questions.choices import DIRECTIONS
from shared.questions.intent import parse_question
from tests.support.scripted_llm import ScriptedLLM

QUESTION = "From image 2, what is behind me? A. A door B. A window C. A bookshelf"
PROGRAM = (
    "def program(input_scene):\n"
    "    recon = pySpatial.reconstruct(input_scene)\n"
    "    return pySpatial.synthesize_novel_view(recon, pySpatial.turn_around(recon.extrinsics[1]))\n"
)


@pytest.fixture()
def client(llm: ScriptedLLM) -> Iterator[ChatClient]:
    llm.reset()
    config = ChatModelConfig(base_url=llm.base_url, model="viewer", timeout_s=5, max_retries=0)
    with ChatClient(config) as chat:
        yield chat


def ask(client: ChatClient, clue_text: str | None = None, clue_images: list[bytes] | None = None):
    return answer_with_model(
        client, parse_question(QUESTION), [b"photo-1", b"photo-2"], PROGRAM, clue_text, clue_images or []
    )


# ---- with a model ------------------------------------------------------------------------------------


def test_structured_json_answer_and_the_prompt(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script([json.dumps({"reasoning": "The render shows shelves.", "answer": "C"})])
    result = ask(client, clue_images=[b"render-1"])
    assert (result.answer, result.method) == ("C", "model_json")
    assert result.reasoning == "The render shows shelves." and result.raw is not None

    (request,) = llm.requests()
    schema = request["response_format"]["json_schema"]["schema"]
    assert request["response_format"]["type"] == "json_schema"
    assert schema["properties"]["answer"]["enum"] == ["A", "B", "C"]
    assert schema["required"] == ["reasoning", "answer"]

    content = request["messages"][0]["content"]
    kinds = [part["type"] for part in content]
    assert kinds.count("image_url") == 3
    texts = [part["text"] for part in content if part["type"] == "text"]
    joined = "\n".join(texts)
    assert QUESTION in joined and PROGRAM.strip() in joined
    assert '{"reasoning":' in joined and "A, B, C" in joined
    assert "Output text: (no text)" in joined
    # Originals first (labelled Image k), then the rendered views (labelled Rendered view k).
    labels = [part["text"] for part in content if part["type"] == "text" and len(part["text"]) < 20]
    assert labels == ["Image 1:", "Image 2:", "Rendered view 1:"]
    order = [content.index({"type": "text", "text": label}) for label in labels]
    assert order == sorted(order)


def test_clue_text_is_in_the_prompt(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(['{"reasoning": "r", "answer": "A"}'])
    ask(client, clue_text="From view 1 to view 2 the camera moved left without turning significantly.")
    joined = "\n".join(part.get("text", "") for part in llm.requests()[0]["messages"][0]["content"])
    assert "Output text: From view 1 to view 2 the camera moved left" in joined


def test_json_in_fences_with_a_wordy_answer(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(['Sure!\n```json\n{"reasoning": "shelves", "answer": "(C) A bookshelf"}\n```'])
    result = ask(client, clue_images=[b"render"])
    assert (result.answer, result.method) == ("C", "model_json")


def test_free_text_fallback(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(["Looking at the rendered view, there are shelves behind you. The answer is **C**."])
    result = ask(client, clue_images=[b"render"])
    assert (result.answer, result.method) == ("C", "model_text")


def test_option_text_fallback(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(["Behind you there is a window."])
    result = ask(client, clue_images=[b"render"])
    assert (result.answer, result.method) == ("B", "model_option_text")


def test_unreadable_reply_gives_none_with_reason(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(["I cannot tell from these images."])
    result = ask(client, clue_images=[b"render"])
    assert result.answer is None and result.method == "none"
    assert "names none of the options A, B, C" in result.reason


def test_server_refusing_json_schema_is_asked_again_without_it(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(
        [{"status": 400, "error_message": "response_format json_schema is not supported"}, "Answer: A"]
    )
    result = ask(client, clue_images=[b"render"])
    assert (result.answer, result.method) == ("A", "model_text")
    first, second = llm.requests()
    assert first["response_format"] is not None and second["response_format"] is None


def test_model_failure_gives_none_with_reason(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script([{"status": 503, "error_message": "warming up"}])
    result = ask(client, clue_images=[b"render"])
    assert result.answer is None and result.method == "none"
    assert (
        "answer model failed" in result.reason
        and "warming up" in result.reason
        and "'viewer'" in result.reason
    )


def test_read_model_answer_ignores_letters_outside_the_options() -> None:
    options = parse_question(QUESTION).options
    assert read_model_answer('{"reasoning": "x", "answer": "E"}', options).answer is None
    # MindCube models answer in lower case too: "b" is option B.
    assert read_model_answer('{"reasoning": "x", "answer": "b"}', options).answer == "B"


# ---- offline -------------------------------------------------------------------------------------------

MOTION_QUESTION = "In which direction did I move from the first view to the second view? " + " ".join(
    f"{letter}. {direction.capitalize()}" for letter, direction in zip("ABCDEFGH", DIRECTIONS, strict=True)
)


@pytest.mark.parametrize("letter, direction", list(zip("ABCDEFGH", DIRECTIONS, strict=True)))
def test_offline_matches_every_direction(letter: str, direction: str) -> None:
    clue = f"From view 1 to view 2 the camera moved {direction} and turned left by about 30 degrees."
    result = answer_offline(parse_question(MOTION_QUESTION), clue, [])
    assert (result.answer, result.method) == (letter, "offline_text")
    assert clue in result.reasoning


@pytest.mark.parametrize(
    ("options", "clue_direction", "answer"),
    [
        ("A. Forward-left B. Forward-right C. Back", "diagonally forward and right", "B"),
        ("A. front left B. front right C. straight ahead", "diagonally forward and left", "A"),
        ("A. backwards B. to the left C. straight ahead", "forward", "C"),
        ("A. moved back and to the right B. moved back and to the left", "diagonally back and left", "B"),
    ],
)
def test_offline_normalizes_option_wording(options: str, clue_direction: str, answer: str) -> None:
    question = "How did I move from view 1 to view 2? " + options
    clue = f"From view 1 to view 2 the camera moved {clue_direction} without turning significantly."
    assert answer_offline(parse_question(question), clue, []).answer == answer


def test_offline_picks_the_asked_pair_among_several_sentences() -> None:
    clue = (
        "From view 1 to view 2 the camera moved forward without turning significantly.\n"
        "From view 2 to view 3 the camera moved left and turned right by about 45 degrees."
    )
    question = "How did I move from image 2 to image 3? A. Forward B. Left C. Right"
    assert answer_offline(parse_question(question), clue, []).answer == "B"
    question = "How did I move from the first image to the second image? A. Forward B. Left C. Right"
    assert answer_offline(parse_question(question), clue, []).answer == "A"


def test_offline_turn_questions_use_side_and_degrees() -> None:
    question = (
        "These two images were taken from the same spot. "
        "How did I turn from the first view to the second view? "
        "A. turned right by about 90 degrees B. turned left by about 45 degrees "
        "C. turned left by about 90 degrees D. did not turn"
    )
    clue = "From view 1 to view 2 the camera stayed in place and turned left by about 90 degrees."
    assert answer_offline(parse_question(question), clue, []).answer == "C"
    still = "From view 1 to view 2 the camera neither moved nor turned significantly."
    assert answer_offline(parse_question(question), still, []).answer == "D"


def test_offline_turn_question_with_bare_sides() -> None:
    question = "Which way did I turn from view 1 to view 2? A. Left B. Right C. Around"
    clue = "From view 1 to view 2 the camera stayed in place and turned right by about 45 degrees."
    assert answer_offline(parse_question(question), clue, []).answer == "B"


def test_turning_is_not_moving() -> None:
    question = "In which direction did I move from view 1 to view 2? A. Left B. Right C. Forward"
    clue = "From view 1 to view 2 the camera stayed in place and turned left by about 90 degrees."
    result = answer_offline(parse_question(question), clue, [])
    assert result.answer is None and "no option states" in result.reason


def test_offline_missing_pair_and_ambiguous_options() -> None:
    clue = "From view 1 to view 2 the camera moved left without turning significantly."
    missing = answer_offline(
        parse_question("How did I move from view 2 to view 3? A. Left B. Right"), clue, []
    )
    assert missing.answer is None and "no sentence about view 2 to view 3" in missing.reason
    twice = answer_offline(
        parse_question("How did I move from view 1 to view 2? A. Left B. to the left"), clue, []
    )
    assert twice.answer is None and "A, B all fit" in twice.reason


def test_offline_image_clue_needs_a_vision_model() -> None:
    result = answer_offline(parse_question(QUESTION), None, [b"render-1", b"render-2"])
    assert result.answer is None and result.method == "none"
    assert "the clue is 2 rendered views" in result.reason
    assert "vision model" in result.reason and "PYSPATIAL_ANSWER_MODEL" in result.reason


def test_offline_other_cases() -> None:
    # No options: a free-form question; the offline rule reads only motion sentences (test_free_form.py).
    behind = answer_offline(parse_question("What is behind me?"), "sofa", [])
    assert behind.answer is None and "only reads camera-motion sentences" in behind.reason
    assert (
        answer_offline(parse_question(QUESTION), "A window", []).answer == "B"
    )  # the output is an option's text
    unreadable = answer_offline(parse_question(QUESTION), "42 points", [])
    assert unreadable.answer is None and "only reads camera-motion sentences" in unreadable.reason
    assert "no clue" in answer_offline(parse_question(QUESTION), "", []).reason
