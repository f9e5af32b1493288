"""The 43 recorded replies of a real code model (Qwen2.5-Coder-1.5B, Q4 GGUF, llama.cpp server).

Each must yield the program the model meant: chosen from its fenced blocks, demo code dropped (and
recorded), then accepted by the real validator, except the replies named here that genuinely
contain no program. They also replay through the scripted OpenAI-compatible server and the real
repair loop. tests/test_model_endpoints.py runs them on a synthetic scene over HTTP.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from services.agent.codegen import ExecutionOutcome, find_program, generate_program
from services.agent.llm import ChatClient, ChatModelConfig
from services.agent.program_cleanup import clean_program
from services.agent.sandbox.validation import ProgramRejected, validate_program
from shared.questions.intent import parse_question
from tests.support.model_replies import recorded_replies
from tests.support.scripted_llm import ScriptedLLM

REPLIES = recorded_replies()
# Replies without any program: the model answered in prose ("The object to the left of you is the
# orange cabinet.") and wrote no code block at all.
WITHOUT_PROGRAM = {18: "among_0002_relative_position_02 attempt 1: prose answer, no code block"}
# Replies whose program the validator must refuse (unsafe): none of the recorded ones.
UNSAFE: dict[int, str] = {}


def cleaned(reply: str) -> tuple[str | None, list[str]]:
    choice = find_program(reply)
    if choice is None:
        return None, []
    result = clean_program(choice.source)
    return result.source, result.dropped


def test_the_fixture_is_the_recorded_file() -> None:
    assert len(REPLIES) == 43
    assert sum(reply.attempt == 1 for reply in REPLIES) == 24  # 24 questions, 19 repairs
    assert all(reply.finish_reason == "stop" for reply in REPLIES)


@pytest.mark.parametrize("reply", REPLIES, ids=lambda reply: reply.name)
def test_each_recorded_reply_yields_the_program_the_model_meant(reply) -> None:
    source, dropped = cleaned(reply.reply)
    if reply.index in WITHOUT_PROGRAM:
        assert source is None
        return
    assert source is not None and source.lstrip().startswith(("def program", "import numpy"))
    if reply.index in UNSAFE:
        with pytest.raises(ProgramRejected):
            validate_program(source)
        return
    validate_program(source)
    for scaffolding in ("print(", "class Scene", "input_scene =", "input_scene.", "import pySpatial", "PIL"):
        assert scaffolding not in source
    if "print(program(input_scene))" in reply.reply:
        assert any("print(program(input_scene))" in line and "demo output" in line for line in dropped)


def test_at_least_39_of_43_pass_the_validator() -> None:
    passed = []
    for reply in REPLIES:
        source, _ = cleaned(reply.reply)
        if source is None:
            continue
        try:
            validate_program(source)
        except ProgramRejected:
            continue
        passed.append(reply.index)
    assert len(passed) >= 39
    assert set(range(43)) - set(passed) == set(WITHOUT_PROGRAM) | set(UNSAFE)


def test_what_was_dropped_from_the_first_reply_is_recorded() -> None:
    _, dropped = cleaned(REPLIES[0].reply)
    assert [line.split(":", 1)[0] for line in dropped] == ["line 3", "line 7", "line 8", "line 12", "line 42"]
    assert "class Scene" in dropped[0] and "stand-in for Scene" in dropped[0]
    assert "input_scene = Scene()" in dropped[1] and "demo output" in dropped[4]


@pytest.fixture()
def coder(llm: ScriptedLLM) -> Iterator[ChatClient]:
    llm.reset()
    config = ChatModelConfig(base_url=llm.base_url, model="qwen-coder", timeout_s=5, max_retries=0)
    with ChatClient(config) as client:
        yield client


def _validate(source: str) -> ExecutionOutcome:
    try:
        validate_program(source)
    except ProgramRejected as rejected:
        return ExecutionOutcome(False, f"rejected: {rejected}", None, "rejected")
    return ExecutionOutcome(True, None, source)


def test_every_recorded_reply_replays_through_the_scripted_server(
    llm: ScriptedLLM, coder: ChatClient
) -> None:
    llm.script([reply.script_entry() for reply in REPLIES], model="qwen-coder")
    outcomes = [
        generate_program(
            coder, parse_question("Which way did I turn? A. left B. right"), [], _validate, max_repairs=0
        )
        for _ in REPLIES
    ]
    assert [index for index, outcome in enumerate(outcomes) if not outcome.ok] == sorted(WITHOUT_PROGRAM)
    assert all(
        o.attempts[0].completion_tokens == r.usage["completion_tokens"]
        for o, r in zip(outcomes, REPLIES, strict=True)
    )
    assert outcomes[18].attempts[0].error_kind == "no_program"


def test_the_recorded_repeat_is_not_run_again(llm: ScriptedLLM, coder: ChatClient) -> None:
    """around_0001_motion_01: attempts 2 and 3 re-sent attempt 2's program unchanged (60-90 s each)."""
    runs: list[str] = []

    def execute(source: str) -> ExecutionOutcome:
        runs.append(source)
        return ExecutionOutcome(False, REPLIES[10].feedback.split("Error:\n", 1)[-1].split("\n")[0], None)

    llm.script(
        [REPLIES[10].script_entry(), REPLIES[11].script_entry(), REPLIES[11].script_entry()],
        model="qwen-coder",
    )
    result = generate_program(
        coder, parse_question("Which way did I move? A. left B. right"), [], execute, max_repairs=2
    )
    assert len(runs) == 1 and result.failure == "repeated"
    assert [attempt.error_kind for attempt in result.attempts] == ["execution", "repeated", "repeated"]
    assert "camera_center" in llm.requests()[1]["messages"][-1]["content"]  # the shape error got the hint


def test_the_prompt_names_everything_the_recorded_programs_reach_for_that_is_not_there() -> None:
    from bench.model_replies import UNAVAILABLE_KINDS, tally_unavailable, unavailable_uses
    from services.agent.prompts import load_template

    assert unavailable_uses(
        "import os\nimport numpy as np\nclass Scene:\n    pass\n"
        "def program(input_scene):\n    return open('path/to/image1.jpg').read() + x.__class__\n"
    ) == {"imports", "os", "classes", "files", "underscores"}
    assert unavailable_uses("import requests\nimport math\ndef program(s):\n    return 1\n") == {
        "imports",
        "network",
    }
    counts = tally_unavailable([{"reply": reply.reply} for reply in REPLIES])
    assert counts["imports"] and counts["files"] and counts["classes"]  # the model did reach for them
    prompt = load_template("codegen").render(**{name: "" for name in load_template("codegen").fields})
    block = prompt.split("## Not available", 1)[1].split("\n## ", 1)[0]
    for kind, words in UNAVAILABLE_KINDS.items():
        assert words in block, f"the prompt's 'Not available' block does not name {kind} ({words!r})"
