"""Ask the code model for a pySpatial program, and repair it when it fails.

`generate_program` sends the codegen prompt (task, API, in-context examples, the photos, the
question), pulls the program out of the reply and hands it to `execute` (the pipeline's validator +
sandbox). When the reply has no program, or the program is rejected or fails, the model sees its own
reply and the error and tries again, up to `max_repairs` more times. Every attempt is recorded.
"""

from __future__ import annotations

import re
import textwrap
import time
from collections.abc import Callable
from typing import Any, Literal, NamedTuple

from pydantic import BaseModel, ConfigDict, Field

from services.agent.example_choice import choose_examples
from services.agent.llm import ChatClient, LLMError, image_part, text_part
from services.agent.prompts import load_template
from shared.question_intent import QuestionIntent

DEFAULT_TEMPLATE = "codegen_v1"
MAX_EXAMPLES = 6  # the examples in the latest codegen_examples_v<N>.md
# An error longer than this is cut before going back to the model: the head says what went wrong.
_MAX_ERROR_CHARS = 2000

_FENCE = re.compile(r"```[ \t]*([A-Za-z0-9_+.-]*)[^\n]*\n(.*?)(?:```|\Z)", re.DOTALL)
_PROGRAM_DEF = re.compile(r"^\s*def\s+program\s*\(", re.MULTILINE)
_PYTHON_TAGS = {"", "python", "py", "python3"}


class ExecutionOutcome(NamedTuple):
    """What the pipeline's `execute` returns for one program."""

    ok: bool
    error: str | None
    payload: Any


class Attempt(BaseModel):
    program: str | None
    reply: str
    error: str | None
    latency_ms: float = Field(description="The model call, retries included.")
    execution_ms: float | None = Field(None, description="Validating and running the program, if it ran.")


class CodegenResult(BaseModel):
    model_config = ConfigDict(arbitrary_types_allowed=True)

    ok: bool
    program: str | None = None
    payload: Any = None
    attempts: list[Attempt] = Field(default_factory=list)
    error: str | None = None
    failure: Literal["no_program", "execution", "model"] | None = None


def extract_program(reply_text: str) -> str | None:
    """The last fenced python block (```python, ```py or no tag) that defines `program`; else None.

    A reply cut off inside its last block still counts. With no fences at all, code starting at a
    line `def program(` is taken as the program.
    """
    candidates = [
        body
        for tag, body in _FENCE.findall(reply_text or "")
        if tag.lower() in _PYTHON_TAGS and _PROGRAM_DEF.search(body)
    ]
    if not candidates and "```" not in (reply_text or ""):
        start = _PROGRAM_DEF.search(reply_text or "")
        if start:
            candidates = [reply_text[start.start() :]]
    if not candidates:
        return None
    return textwrap.dedent(candidates[-1]).strip("\n") + "\n"


def _render_examples(count: int, intent: QuestionIntent | None = None) -> str:
    if not 0 <= count <= MAX_EXAMPLES:
        raise ValueError(f"num_examples must be between 0 and {MAX_EXAMPLES}, got {count}")
    # The examples most like the question come first (services/agent/example_choice.py).
    examples = choose_examples(count, intent)
    if not examples:
        return ""
    blocks = ["## Examples", "Each example is a question and a program that produces a useful clue for it."]
    for index, example in enumerate(examples, start=1):
        blocks.append(f"### Example {index}\n\nQuestion: {example.question}\n\n```python\n{example.code}```")
    return "\n\n".join(blocks)


def build_codegen_messages(
    question: str,
    images_png: list[bytes],
    num_examples: int = 2,
    template_version: str = DEFAULT_TEMPLATE,
    attach_images: bool = True,
    intent: QuestionIntent | None = None,
) -> list[dict[str, Any]]:
    """The chat messages of the first code request: one user message, text then the photos.

    `attach_images=False` is for text-only code models: the prompt still says how many photos exist.
    """
    template = load_template(template_version)
    text = template.render(
        examples=_render_examples(num_examples, intent),
        num_images=len(images_png),
        question=question.strip(),
    )
    content: list[dict[str, Any]] = [text_part(text)]
    if attach_images:
        for index, png in enumerate(images_png, start=1):
            content.append(text_part(f"Image {index}:"))
            content.append(image_part(png))
    return [{"role": "user", "content": content}]


def _repair_message(error: str | None) -> dict[str, Any]:
    template = load_template("repair")
    if error is None:
        problem = "Your reply did not contain a program."
        detail = "I need the code in a ```python block that defines `def program(input_scene):`."
    else:
        problem = "Your program failed."
        detail = error if len(error) <= _MAX_ERROR_CHARS else error[:_MAX_ERROR_CHARS] + " [...]"
        detail = f"Error:\n{detail}"
    return {"role": "user", "content": template.render(problem=problem, detail=detail)}


def generate_program(
    client: ChatClient,
    question: str,
    images_png: list[bytes],
    execute: Callable[[str], ExecutionOutcome | tuple[bool, str | None, Any]],
    max_repairs: int = 2,
    num_examples: int = 2,
    template_version: str = DEFAULT_TEMPLATE,
    attach_images: bool = True,
    intent: QuestionIntent | None = None,
) -> CodegenResult:
    """Generate, run and repair a program; see the module docstring.

    Model failures (ModelUnavailable / ModelError) end the loop with `failure="model"` and the
    attempts made so far, so the caller can fall back (e.g. to the offline planner).
    """
    if max_repairs < 0:
        raise ValueError(f"max_repairs must be >= 0, got {max_repairs}")
    messages = build_codegen_messages(
        question, images_png, num_examples, template_version, attach_images, intent=intent
    )
    attempts: list[Attempt] = []
    last_error = "no attempt made"
    failure: Literal["no_program", "execution", "model"] = "no_program"
    for _ in range(max_repairs + 1):
        try:
            reply = client.complete(messages)
        except LLMError as model_error:
            return CodegenResult(ok=False, attempts=attempts, error=str(model_error), failure="model")
        program = extract_program(reply.text)
        attempt = Attempt(program=program, reply=reply.text, error=None, latency_ms=reply.latency_ms)
        attempts.append(attempt)
        if program is None:
            attempt.error = last_error = "the reply contained no ```python block defining program()"
            failure = "no_program"
            feedback = None
        else:
            started = time.perf_counter()
            ok, error, payload = execute(program)
            attempt.execution_ms = (time.perf_counter() - started) * 1000.0
            if ok:
                return CodegenResult(ok=True, program=program, payload=payload, attempts=attempts)
            attempt.error = last_error = feedback = error or "the program failed without an error message"
            failure = "execution"
        messages = [*messages, {"role": "assistant", "content": reply.text}, _repair_message(feedback)]
    return CodegenResult(
        ok=False,
        attempts=attempts,
        error=f"no working program after {len(attempts)} attempt(s); last error: {last_error}",
        failure=failure,
    )


__all__ = [
    "Attempt",
    "CodegenResult",
    "ExecutionOutcome",
    "build_codegen_messages",
    "extract_program",
    "generate_program",
]
