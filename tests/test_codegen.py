"""Code prompt, program extraction and the self-repair loop against a scripted model server."""

from __future__ import annotations

import ast
from collections.abc import Iterator

import pytest

from services.agent.codegen import ExecutionOutcome, build_codegen_messages, extract_program, generate_program
from services.agent.llm import ChatClient, ChatModelConfig
from services.agent.prompts import PromptError, load_examples, load_template
from services.agent.sandbox.validation import ProgramRejected, validate_program
from tests.support.scripted_llm import ScriptedLLM

PNG = b"\x89PNG\r\n\x1a\n not decoded by anyone here"
QUESTION = "From image 2, what is behind me? A. A door B. A window"
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
    return "\n".join(part["text"] for part in messages[0]["content"] if part["type"] == "text")


# ---- the prompt -----------------------------------------------------------------------------------


def test_prompt_has_the_api_specification_and_conventions() -> None:
    text = prompt_text(build_codegen_messages(QUESTION, [PNG, PNG]))
    for signature in (
        "pySpatial.reconstruct(scene) -> Reconstruction",
        "pySpatial.describe_camera_motion(recon) -> str",
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
    text = prompt_text(build_codegen_messages(QUESTION, [PNG], num_examples=count))
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
        build_codegen_messages(QUESTION, [PNG], num_examples=7)


def test_images_follow_the_text_in_order_or_not_at_all() -> None:
    content = build_codegen_messages(QUESTION, [b"one", b"two"])[0]["content"]
    assert [part["type"] for part in content] == ["text", "text", "image_url", "text", "image_url"]
    assert content[1]["text"] == "Image 1:" and content[3]["text"] == "Image 2:"
    text_only = build_codegen_messages(QUESTION, [b"one", b"two"], attach_images=False)[0]["content"]
    assert [part["type"] for part in text_only] == ["text"]


def test_template_is_versioned_and_strict() -> None:
    template = load_template("codegen")
    assert (template.name, template.version, template.id) == ("codegen", 1, "codegen_v1")
    assert template.fields == {"examples", "num_images", "question"}
    with pytest.raises(PromptError, match="missing fields"):
        template.render(question="q", num_images=1)
    with pytest.raises(PromptError, match="unexpected fields"):
        template.render(question="q", num_images=1, examples="", extra="x")
    with pytest.raises(PromptError):
        load_template("codegen_v99")


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
    result = generate_program(client, QUESTION, [PNG, PNG], validate_only)
    assert result.ok and result.failure is None
    assert "turn_around(recon.extrinsics[1])" in result.program
    assert isinstance(result.payload, ast.Module)
    (attempt,) = result.attempts
    assert attempt.error is None and attempt.reply == GOOD_REPLY and attempt.latency_ms > 0
    assert attempt.execution_ms is not None


def test_rejected_program_is_repaired(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script([IMPORTING_REPLY, GOOD_REPLY])
    result = generate_program(client, QUESTION, [PNG], validate_only, max_repairs=2)
    assert result.ok
    assert [attempt.error is None for attempt in result.attempts] == [False, True]
    assert "imports are not allowed" in result.attempts[0].error
    first, second = llm.requests()
    repair = second["messages"]
    assert len(repair) == 3
    assert repair[0] == first["messages"][0]
    assert repair[1] == {"role": "assistant", "content": IMPORTING_REPLY}
    assert repair[2]["role"] == "user"
    assert "Your program failed" in repair[2]["content"] and "imports are not allowed" in repair[2]["content"]


def test_reply_without_code_asks_again(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(["I think the answer is A.", GOOD_REPLY])
    result = generate_program(client, QUESTION, [PNG], validate_only)
    assert result.ok
    assert result.attempts[0].program is None
    assert "no ```python block" in result.attempts[0].error
    repair = llm.requests()[1]["messages"][2]["content"]
    assert "did not contain a program" in repair


def test_repairs_exhausted(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script([IMPORTING_REPLY, "no code, sorry", IMPORTING_REPLY, GOOD_REPLY])
    result = generate_program(client, QUESTION, [PNG], validate_only, max_repairs=2)
    assert not result.ok and result.program is None and result.failure == "execution"
    assert len(result.attempts) == 3
    assert "3 attempt(s)" in result.error and "imports are not allowed" in result.error
    assert len(llm.requests()) == 3  # the fourth (good) reply was never asked for
    assert len(llm.requests()[2]["messages"]) == 5


def test_zero_repairs_means_one_attempt(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script(["no code", GOOD_REPLY])
    result = generate_program(client, QUESTION, [PNG], validate_only, max_repairs=0)
    assert not result.ok and result.failure == "no_program" and len(result.attempts) == 1


def test_execution_errors_are_fed_back(llm: ScriptedLLM, client: ChatClient) -> None:
    runs: list[str] = []

    def execute(source: str) -> ExecutionOutcome:
        runs.append(source)
        if len(runs) == 1:
            return ExecutionOutcome(False, "IndexError: list index out of range (line 3)", None)
        return ExecutionOutcome(True, None, "clue")

    llm.script([GOOD_REPLY, GOOD_REPLY.replace("extrinsics[1]", "extrinsics[0]")])
    result = generate_program(client, QUESTION, [PNG], execute)
    assert result.ok and result.payload == "clue" and len(runs) == 2
    assert "IndexError: list index out of range" in llm.requests()[1]["messages"][2]["content"]


def test_model_failure_ends_the_loop_with_the_attempts_so_far(llm: ScriptedLLM, client: ChatClient) -> None:
    llm.script([IMPORTING_REPLY, {"status": 400, "error_message": "context length exceeded"}])
    result = generate_program(client, QUESTION, [PNG], validate_only)
    assert not result.ok and result.failure == "model"
    assert len(result.attempts) == 1
    assert "context length exceeded" in result.error and "'coder'" in result.error
