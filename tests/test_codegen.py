"""Code prompt, program extraction and the self-repair loop against a scripted model server."""

from __future__ import annotations

import ast
import inspect
import re
from collections.abc import Iterator

import pytest

from services.agent.codegen import (
    DEFAULT_TEMPLATE,
    ExecutionOutcome,
    build_codegen_messages,
    extract_program,
    generate_program,
    repair_hints,
)
from services.agent.llm import ChatClient, ChatModelConfig
from services.agent.prompts import PromptError, load_examples, load_template
from services.agent.sandbox.api import PySpatial
from services.agent.sandbox.validation import ProgramRejected, validate_program
from services.agent.steps import SolveLog
from shared.questions.intent import parse_question
from shared.wire.schemas import ProgramStep
from tests.support.scripted_llm import ScriptedLLM

PNG = b"\x89PNG\r\n\x1a\n not decoded by anyone here"
QUESTION = "From image 2, what is behind me? A. A door B. A window"
INTENT = parse_question(QUESTION)
GOOD_REPLY = """The photographer of image 2 needs to look back, so turn that camera around.

```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.synthesize_novel_view(recon, pySpatial.turn_around(recon.extrinsics[1]))
```"""
IMPORTING_REPLY = """```python
import os

def program(input_scene):
    return os.listdir("/")
```"""


def validate_only(source: str) -> ExecutionOutcome:
    """The pipeline validates and runs; here the real validator alone decides."""
    try:
        tree = validate_program(source)
    except ProgramRejected as rejected:
        return ExecutionOutcome(ok=False, error=f"rejected: {rejected}", payload=None)
    return ExecutionOutcome(ok=True, error=None, payload=tree)


@pytest.fixture()
def client(llm: ScriptedLLM) -> Iterator[ChatClient]:
    llm.reset()
    with ChatClient(
        ChatModelConfig(base_url=llm.base_url, model="coder", timeout_s=5, max_retries=0)
    ) as chat:
        yield chat


def prompt_text(messages: list[dict]) -> str:
    content = messages[0]["content"]
    if isinstance(content, str):
        return content
    return "\n".join(part["text"] for part in content if part["type"] == "text")


# ---- the prompt -----------------------------------------------------------------------------------


def test_prompt_has_the_api_specification_and_conventions() -> None:
    text = prompt_text(build_codegen_messages(INTENT, [PNG, PNG]))
    for signature in (
        "pySpatial.reconstruct(scene) -> Reconstruction",
        "pySpatial.describe_camera_motion(recon, from_view=None, to_view=None) -> str",
        "pySpatial.synthesize_novel_view(recon, new_extrinsic, width=512, height=512) -> Image",
        "pySpatial.rotate_left(extrinsic, angle=45)",
        "pySpatial.rotate_right(extrinsic, angle=45)",
        "pySpatial.move_forward(extrinsic, distance=0.3)",
        "pySpatial.move_backward(extrinsic, distance=0.3)",
        "pySpatial.turn_around(extrinsic)",
    ):
        assert signature in text
    assert "x points right, y points down, z points forward" in text
    assert "camera-from-world" in text or "world to camera" in text
    assert "def program(input_scene)" in text and "```python" in text
    assert "Question: " + QUESTION in text
    assert "There are 2 photo(s)" in text


@pytest.mark.parametrize("count", [0, 1, 2, 3, 4, 5, 6])
def test_prompt_has_the_requested_number_of_examples(count: int) -> None:
    text = prompt_text(build_codegen_messages(INTENT, [PNG], num_examples=count, rank_examples=False))
    assert text.count("### Example ") == count
    examples = load_examples("codegen_examples")  # without an intent: file order
    for shown in examples[:count]:
        assert shown.code in text
    for hidden in examples[count:]:
        assert hidden.code not in text


def test_examples_are_valid_programs_without_answers() -> None:
    examples = load_examples("codegen_examples")
    assert len(examples) == 6
    for example in examples:
        validate_program(example.code)
        assert "answer" not in example.code.lower()


def test_num_examples_out_of_range() -> None:
    with pytest.raises(ValueError, match="between 0 and 6"):
        build_codegen_messages(INTENT, [PNG], num_examples=7)


def test_images_follow_the_text_in_order_or_not_at_all() -> None:
    content = build_codegen_messages(INTENT, [b"one", b"two"])[0]["content"]
    assert [part["type"] for part in content] == ["text", "text", "image_url", "text", "image_url"]
    assert content[1]["text"] == "Image 1:" and content[3]["text"] == "Image 2:"
    text_only = build_codegen_messages(INTENT, [b"one", b"two"], attach_images=False)[0]["content"]
    assert isinstance(text_only, str)  # plain string content: what text-only chat templates accept
    assert "There are 2 photo(s). You do not see them" in text_only and "image_url" not in text_only


def test_template_is_versioned_and_strict() -> None:
    template = load_template("codegen")
    assert (template.name, template.version, template.id) == ("codegen", 4, "codegen_v4")
    assert "pySpatial.plan_route(recon, start_view, goal" in template.text  # issue 23's tools
    assert template.fields == {"examples", "photos", "question"}
    assert load_template("codegen_v1").fields == {"examples", "num_images", "question"}  # still there
    with pytest.raises(PromptError, match="missing fields"):
        template.render(question="q", photos="")
    with pytest.raises(PromptError, match="unexpected fields"):
        template.render(question="q", photos="", examples="", extra="x")
    with pytest.raises(PromptError):
        load_template("codegen_v99")


# ---- the prompt's API page against the API's own conventions --------------------------------------

VIEW_BASE = re.compile(r"\b([01])-based\b")
TURN_SIGN = re.compile(r"\+ = (left|right)|\b(left|right)-positive")
UNITS = ("scene units", "metres", "pixels", "degrees")
DISTANCES = {"distance", "robot_radius", "goal", "point"}  # arguments that are lengths or positions


def _page_entries(text: str) -> dict[str, tuple[list[str], str]]:
    """Each `def pySpatial.NAME(args)` of the prompt's API page: its argument names and docstring."""
    found = re.findall(r'def pySpatial\.(\w+)\(([^)]*)\)[^\n]*:\n\s*"""(.*?)"""', text, re.S)
    return {
        name: ([a.split("=")[0].strip() for a in args.split(",") if a.strip()], doc)
        for name, args, doc in found
    }


def _sides(text: str) -> set[str]:
    return {side for pair in TURN_SIGN.findall(text) for side in pair if side}


def _program_api() -> dict[str, tuple[list[str], str]]:
    """Every tool a program calls: its argument names and docstring, from the class itself."""
    tools = {}
    for name, member in vars(PySpatial).items():
        if name.startswith("_") or not inspect.isfunction(member):
            continue
        arguments = [a for a in inspect.signature(member).parameters if a != "self"]
        tools[name] = (arguments, " ".join((inspect.getdoc(member) or "").split()))
    return tools


def test_the_prompts_api_page_states_the_apis_view_base_turn_sign_and_units() -> None:
    text = load_template(DEFAULT_TEMPLATE).text
    page = _page_entries(text)
    api = _program_api()
    assert set(api) == set(page), "the API page lists every tool and only those"
    for name, (arguments, doc) in api.items():
        page_arguments, page_doc = page[name]
        page_doc = " ".join(page_doc.split())
        assert page_arguments == arguments, name
        if any(argument.endswith("view") for argument in arguments):  # a view argument's base
            assert set(VIEW_BASE.findall(doc)) == {"1"}, f"{name}: the API names no 1-based view"
            assert set(VIEW_BASE.findall(page_doc)) == {"1"}, f"{name}: the page names no 1-based view"
        assert _sides(doc) <= {"left"} and _sides(page_doc) == _sides(doc), f"{name}: the turn sign"
        if "degrees" in doc.lower() and not _sides(doc):  # an unsigned angle: its name says which way
            assert any(way in name for way in ("left", "right", "around")), name
        for unit in UNITS:
            assert unit not in doc.lower() or unit in page_doc.lower(), f"{name}: the page omits {unit}"
        if DISTANCES & set(arguments):
            assert "scene units" in doc or "metres" in doc, f"{name}: a length without its unit"
    rules = " ".join(text.split("## API")[0].split())
    assert "1-based" in rules and "+ = left, - = right" in rules and "scene units" in rules


# ---- extracting the program -----------------------------------------------------------------------


def test_extract_the_last_python_block_defining_program() -> None:
    reply = (
        "First a sketch:\n```python\ndef helper():\n    pass\n```\n"
        "```python\ndef program(input_scene):\n    return 'first'\n```\n"
        "Better:\n```python\ndef program(input_scene):\n    return 'second'\n```\nDone."
    )
    assert extract_program(reply) == "def program(input_scene):\n    return 'second'\n"


@pytest.mark.parametrize("fence", ["```py", "```", "```Python", "```python3"])
def test_extract_tolerates_tags(fence: str) -> None:
    reply = f"Here:\n{fence}\ndef program(input_scene):\n    return 1\n```"
    assert extract_program(reply) == "def program(input_scene):\n    return 1\n"


def test_extract_other_languages_and_missing_program() -> None:
    assert extract_program('```json\n{"def program(": 1}\n```') is None
    assert extract_program("I cannot help with that.") is None
    assert extract_program("```python\nprint('no program here')\n```") is None


def test_extract_unclosed_block_and_bare_code() -> None:
    assert extract_program("```python\ndef program(input_scene):\n    return 2\n") == (
        "def program(input_scene):\n    return 2\n"
    )
    assert extract_program("Sure.\ndef program(input_scene):\n    return 3") == (
        "def program(input_scene):\n    return 3\n"
    )


# ---- the repair loop ----------------------------------------------------------------------------------


def test_good_program_first_time(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script([GOOD_REPLY])
    result = generate_program(client, INTENT, [PNG, PNG], validate_only)
    assert result.ok and result.failure is None
    assert "turn_around(recon.extrinsics[1])" in result.program
    assert isinstance(result.payload, ast.Module)
    (attempt,) = result.attempts
    assert attempt.error is None and attempt.reply == GOOD_REPLY and attempt.latency_ms > 0
    assert attempt.execution_ms is not None


def test_rejected_program_is_repaired(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script([IMPORTING_REPLY, GOOD_REPLY])
    result = generate_program(client, INTENT, [PNG], validate_only, max_repairs=2)
    assert result.ok
    assert [attempt.error is None for attempt in result.attempts] == [False, True]
    assert "imports are not allowed" in result.attempts[0].error
    assert "import os" in result.attempts[0].program  # used by program(): kept, and the validator refuses it
    first, second = llm.requests()
    repair = second["messages"]
    assert len(repair) == 3
    assert repair[0] == first["messages"][0]
    assert repair[1] == {"role": "assistant", "content": IMPORTING_REPLY}
    assert repair[2]["role"] == "user"
    assert "Your program failed" in repair[2]["content"] and "imports are not allowed" in repair[2]["content"]


def test_reply_without_code_asks_again(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(["I think the answer is A.", GOOD_REPLY])
    result = generate_program(client, INTENT, [PNG], validate_only)
    assert result.ok
    assert result.attempts[0].program is None
    assert "no ```python block" in result.attempts[0].error
    repair = llm.requests()[1]["messages"][2]["content"]
    assert "did not contain a program" in repair


def test_repairs_exhausted(llm: ScriptedLLM, client: ChatClient) -> None:
    importing_sys = IMPORTING_REPLY.replace("os", "sys")
    llm.script([IMPORTING_REPLY, "no code, sorry", importing_sys, GOOD_REPLY])
    result = generate_program(client, INTENT, [PNG], validate_only, max_repairs=2)
    assert not result.ok and result.program is None and result.failure == "execution"
    assert len(result.attempts) == 3
    assert "3 attempt(s)" in result.error and "imports are not allowed" in result.error
    assert [attempt.error_kind for attempt in result.attempts] == ["execution", "no_program", "execution"]
    assert len(llm.requests()) == 3  # the fourth (good) reply was never asked for
    assert len(llm.requests()[2]["messages"]) == 5


def test_zero_repairs_means_one_attempt(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(["no code", GOOD_REPLY])
    result = generate_program(client, INTENT, [PNG], validate_only, max_repairs=0)
    assert not result.ok and result.failure == "no_program" and len(result.attempts) == 1


def test_execution_errors_are_fed_back(llm: ScriptedLLM, client: ChatClient) -> None:
    runs: list[str] = []

    def execute(source: str) -> ExecutionOutcome:
        runs.append(source)
        if len(runs) == 1:
            return ExecutionOutcome(False, "IndexError: list index out of range (line 3)", None)
        return ExecutionOutcome(True, None, "clue")

    llm.script([GOOD_REPLY, GOOD_REPLY.replace("extrinsics[1]", "extrinsics[0]")])
    result = generate_program(client, INTENT, [PNG], execute)
    assert result.ok and result.payload == "clue" and len(runs) == 2
    assert "IndexError: list index out of range" in llm.requests()[1]["messages"][2]["content"]


def test_a_spent_solve_budget_ends_the_loop_without_asking_for_a_repair(
    llm: ScriptedLLM, client: ChatClient
) -> None:
    spent = "cpu_budget: this solve's programs used 2.0 s of CPU, its budget is 2 s across all attempts"
    outcomes = iter([ExecutionOutcome(False, "CPU limit of 1 s exceeded", None, "cpu")])

    def execute(source: str) -> ExecutionOutcome:
        return next(outcomes, ExecutionOutcome(False, spent, None, "cpu_budget"))

    llm.script([GOOD_REPLY, GOOD_REPLY.replace("[1]", "[0]"), GOOD_REPLY.replace("[1]", "[2]")])
    result = generate_program(client, INTENT, [PNG], execute, max_repairs=2)
    assert not result.ok and result.failure == "budget"
    assert [attempt.error_kind for attempt in result.attempts] == ["cpu", "cpu_budget"]
    assert result.error.endswith(spent) and len(llm.requests()) == 2  # the third reply never asked for


def test_model_failure_ends_the_loop_with_the_attempts_so_far(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script([IMPORTING_REPLY, {"status": 400, "error_message": "context length exceeded"}])
    result = generate_program(client, INTENT, [PNG], validate_only)
    assert not result.ok and result.failure == "model"
    assert len(result.attempts) == 1
    assert "context length exceeded" in result.error and "'coder'" in result.error


# ---- parsing real replies: blocks, demo code, size --------------------------------------------------


def test_the_block_that_parses_wins_and_helpers_from_other_blocks_are_kept() -> None:
    reply = (
        "Helper first:\n```python\ndef facing(pose):\n    return pose[2, :3]\n```\n"
        "Program:\n```python\ndef program(input_scene):\n    recon = pySpatial.reconstruct(input_scene)\n"
        "    return str(facing(recon.extrinsics[0]))\n```\n"
        "A variant I did not finish:\n```python\ndef program(input_scene):\n    return (\n```\n"
        "Example usage:\n```python\nprint(program(input_scene))\n```"
    )
    source = extract_program(reply)
    assert source.startswith("def facing(pose):") and "str(facing(recon.extrinsics[0]))" in source
    validate_program(source)


def test_demo_code_around_a_good_program_is_dropped_and_recorded(
    llm: ScriptedLLM, client: ChatClient
) -> None:
    reply = (
        "```python\nimport numpy as np\nimport pySpatial\n\nclass Scene:\n    images: list\n\n"
        "input_scene = Scene()\nSTEP = 0.5\n\ndef program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    ahead = pySpatial.move_forward(recon.extrinsics[0], STEP)\n"
        "    return pySpatial.synthesize_novel_view(recon, ahead)\n"
        "\n# Example usage\nif __name__ == '__main__':\n    print(program(input_scene))\n"
        "print(program(input_scene))\n```"
    )
    llm.script([reply])
    result = generate_program(client, INTENT, [PNG], validate_only, max_repairs=0)
    assert result.ok, result.error
    (attempt,) = result.attempts
    assert "STEP = 0.5" in result.program and "import numpy as np" in result.program
    for gone in ("class Scene", "input_scene = Scene()", "print(", "__main__", "import pySpatial", "Example"):
        assert gone not in result.program
    reasons = " | ".join(attempt.dropped)
    assert "line 2: import pySpatial" in reasons and "line 4: class Scene:" in reasons
    assert "line 7: input_scene = Scene()" in reasons and "script entry point" in reasons
    assert "demo output" in reasons and len(attempt.dropped) == 5


def test_regex_bombs_parse_in_one_pass() -> None:
    # 80 KB of this took the old fence regex 11 s; the scanner reads each line once.
    assert extract_program("```python " * 40_000) is None
    assert extract_program("```python \n" * 40_000) is None
    assert extract_program("```\n" + "def program(input_scene):\n" * 20_000) is not None


def test_an_oversized_reply_is_refused_unread(llm: ScriptedLLM, client: ChatClient) -> None:
    huge = GOOD_REPLY + "\n" + "x" * 5000
    llm.script([huge, GOOD_REPLY])
    result = generate_program(client, INTENT, [PNG], validate_only, max_reply_chars=4000)
    assert result.ok and len(result.attempts) == 2
    first = result.attempts[0]
    assert first.error_kind == "too_long" and first.program is None and "not read" in first.error
    assert len(first.reply) < 2100  # the record keeps the head only
    repair = llm.requests()[1]["messages"][-1]["content"]
    assert "far too long" in repair and "5" in repair


# ---- repairs that change something ------------------------------------------------------------------


def test_an_identical_program_is_never_run_again(llm: ScriptedLLM, client: ChatClient) -> None:
    runs: list[str] = []

    def execute(source: str) -> ExecutionOutcome:
        runs.append(source)
        return ExecutionOutcome(False, "program raised ValueError: shapes (4,4) and (3,) not aligned", None)

    same_again = GOOD_REPLY.replace("The photographer", "Fixed! The photographer") + "\n# no change"
    llm.script([GOOD_REPLY, same_again, GOOD_REPLY, GOOD_REPLY])
    result = generate_program(client, INTENT, [PNG], execute, max_repairs=3)
    assert len(runs) == 1  # the same program (same syntax tree) is not run twice
    assert not result.ok and result.failure == "repeated"
    assert [a.error_kind for a in result.attempts] == ["execution", "repeated", "repeated"]
    assert "same program as attempt 1" in result.attempts[1].error
    assert len(llm.requests()) == 3  # stopped early: the fourth reply was never asked for
    temperatures = [request["body"]["temperature"] for request in llm.requests()]
    assert temperatures[0] == 0.0 and temperatures[1] > temperatures[0] and temperatures[2] > temperatures[1]
    repair = llm.requests()[2]["messages"][-1]["content"]
    assert "identical to attempt 1" in repair and "pySpatial.camera_center" in repair


@pytest.mark.parametrize(
    ("error", "expected"),
    [
        ("ValueError: matmul: Input operand 1 has a mismatch in its core dimension 0", "4x4"),
        ("ValueError: shapes (4,4) and (3,) not aligned: 4 (dim 1) != 3 (dim 0)", "camera_center"),
        ("ValueError: The truth value of an array with more than one element is ambiguous", "np.allclose"),
        ("TypeError: 'Image' object is not iterable", "image handle"),
        ("LinAlgError: Last 2 dimensions of the array must be square", "relative_pose"),
    ],
)
def test_known_mistakes_get_a_hint_that_names_the_helper(error: str, expected: str) -> None:
    assert any(expected in hint for hint in repair_hints(error))
    assert repair_hints("NameError: name 'recon' is not defined") == []


def test_the_same_prose_twice_more_ends_the_loop(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(["The answer is B.", "The answer is  B.", "The answer is B.", GOOD_REPLY])
    result = generate_program(client, INTENT, [PNG], validate_only, max_repairs=4)
    assert not result.ok and len(result.attempts) == 3 and len(llm.requests()) == 3


def test_each_request_is_a_program_step_of_the_log(llm: ScriptedLLM, client: ChatClient) -> None:
    """One ProgramStep per request: what it asked for, the program it handed on, or why none."""
    runs: list[str] = []

    def execute(source: str) -> ExecutionOutcome:
        runs.append(source)
        return ExecutionOutcome(len(runs) > 1, None if len(runs) > 1 else "program raised ValueError", None)

    other = GOOD_REPLY.replace("recon.extrinsics[1]", "recon.extrinsics[0]")
    llm.script(["I think the answer is A.", GOOD_REPLY, GOOD_REPLY, other])
    log = SolveLog()
    result = generate_program(client, INTENT, [PNG], execute, max_repairs=3, log=log)
    assert result.ok and len(runs) == 2
    steps = log.of(ProgramStep)
    assert [step.attempt for step in steps] == [1, 2, 3, 4] and {step.author for step in steps} == {"coder"}
    assert [step.error_kind for step in steps] == ["no_program", None, "repeated", None]
    assert [step.repairs for step in steps] == [None, None, 1, None]  # after the run that failed
    assert steps[0].program is None and "no ```python block" in steps[0].error
    assert steps[1].program == runs[0] and steps[3].program == runs[1] == result.program
    assert steps[2].program is None and "same program as attempt 2" in steps[2].error  # not run again
    assert all(step.duration_ms >= 0 and step.stage == "program" for step in steps)
