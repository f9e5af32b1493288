"""Ask the code model for a pySpatial program, and repair it when it fails.

`generate_program` sends the codegen prompt (task, API, in-context examples, the photos unless the
model is text-only, the question), takes the program out of the reply and hands it to `execute`
(the pipeline's validator + sandbox). When the reply has no program, or the program is rejected or
fails, the model sees its own reply and the error, with a hint where the error is a known mistake,
and tries again, up to `max_repairs` more times. Every attempt is recorded.

Taking the program out of a reply (all linear in the reply's length, and replies longer than
`max_reply_chars` are refused unread, so a hostile or runaway reply cannot stall the service):
  1. reply_blocks finds the fenced blocks in one pass; the python block that defines `program` is
     chosen (one that parses before one that does not, a closed one before a cut-off one, then the
     last), and helpers it calls that only another block defines are added;
  2. program_cleanup drops top-level demo code (prints, stub classes, stand-in scenes), recording
     what it dropped.

Repairs that change something: a program identical to one that already failed (same syntax tree)
is never run again; the model is told so, plainly; each repair raises the temperature; when the
model repeats itself a second time the loop stops early. A run refused because the solve's CPU
budget is spent ends the loop at once (`failure="budget"`): no later program could run.
"""

from __future__ import annotations

import ast
import re
import textwrap
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple

from pydantic import BaseModel, ConfigDict, Field

from services.agent.example_choice import choose_examples
from services.agent.llm import ChatClient, ChatReply, LLMError, image_part, text_part
from services.agent.program_cleanup import UNPARSABLE_ERRORS, clean_program, program_fingerprint
from services.agent.prompts import load_template
from services.agent.repair_hints import pointed_hints
from services.agent.reply_blocks import CodeBlock, code_blocks, defines_function, unfenced_function
from services.agent.steps import SolveLog
from shared.questions.intent import QuestionIntent
from shared.wire.schemas import ProgramStep

DEFAULT_TEMPLATE = "codegen_v4"
REPAIR_TEMPLATE = "repair_v2"
MAX_EXAMPLES = 6  # the examples in the latest codegen_examples_v<N>.md
DEFAULT_MAX_REPLY_CHARS = 60_000
REPAIR_TEMPERATURE_STEP = 0.3  # added per repair, so a repair is not the same draw again
MAX_TEMPERATURE = 1.0
REPEATS_BEFORE_STOPPING = 2
# An error longer than this is cut before going back to the model: the head says what went wrong.
_MAX_ERROR_CHARS = 2000
PROGRAM_NAME = "program"

Failure = Literal["no_program", "execution", "model", "repeated", "budget"]
# Error kinds after which no program of this solve can run (its CPU budget is spent): the loop ends
# there, since a repair request would cost a model call for a program that is refused unrun.
FINAL_ERROR_KINDS = frozenset({"cpu_budget"})


class ExecutionOutcome(NamedTuple):
    """What the pipeline's `execute` returns for one program."""

    ok: bool
    error: str | None
    payload: Any
    error_kind: str | None = None  # rejected | exception | timeout | ... (the sandbox's kinds)


class Attempt(BaseModel):
    program: str | None
    reply: str
    error: str | None
    error_kind: str | None = Field(
        None, description="no_program | too_long | repeated | the sandbox's kind (rejected, exception, ...)"
    )
    dropped: list[str] = Field(
        default_factory=list, description="Top-level demo code removed from the reply."
    )
    temperature: float | None = None
    finish_reason: str | None = None
    prompt_tokens: int | None = None
    completion_tokens: int | None = None
    latency_ms: float = Field(description="The model call, retries included.")
    execution_ms: float | None = Field(None, description="Validating and running the program, if it ran.")


class CodegenResult(BaseModel):
    model_config = ConfigDict(arbitrary_types_allowed=True)

    ok: bool
    program: str | None = None
    payload: Any = None
    attempts: list[Attempt] = Field(default_factory=list)
    error: str | None = None
    failure: Failure | None = None
    model_error: LLMError | None = Field(None, exclude=True, description="The exception of failure='model'.")


class ProgramChoice(NamedTuple):
    source: str  # the chosen block (dedented), with helpers from other blocks prepended
    blocks: int  # python blocks in the reply
    helpers_from_other_blocks: list[str]


def _parses(code: str) -> ast.Module | None:
    try:
        return ast.parse(code)
    except UNPARSABLE_ERRORS:
        return None


def _missing_helpers(chosen: ast.Module, others: list[CodeBlock]) -> tuple[list[str], list[str]]:
    """Top-level functions `chosen` calls but defines nowhere, taken from the reply's other blocks."""
    defined = {node.name for node in chosen.body if isinstance(node, ast.FunctionDef)}
    wanted = {node.id for node in ast.walk(chosen) if isinstance(node, ast.Name)} - defined
    sources, names = [], []
    for block in others:
        tree = _parses(textwrap.dedent(block.code))
        if tree is None:
            continue
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and node.name in wanted and node.name != PROGRAM_NAME:
                segment = ast.get_source_segment(textwrap.dedent(block.code), node)
                if segment:
                    sources.append(segment)
                    names.append(node.name)
                    wanted.discard(node.name)
    return sources, names


def find_program(reply_text: str) -> ProgramChoice | None:
    """The program in a reply (see the module docstring), or None when it has none."""
    text = reply_text or ""
    blocks = [block for block in code_blocks(text) if block.is_python]
    candidates = [block for block in blocks if defines_function(block.code, PROGRAM_NAME)]
    if not candidates:
        if blocks or "```" in text:
            return None
        bare = unfenced_function(text, PROGRAM_NAME)
        return ProgramChoice(bare, 0, []) if bare else None
    ranked = [
        (_parses(textwrap.dedent(block.code)) is not None, block.closed, index)
        for index, block in enumerate(candidates)
    ]
    best = max(range(len(candidates)), key=lambda index: ranked[index])
    chosen = textwrap.dedent(candidates[best].code).strip("\n") + "\n"
    tree = _parses(chosen)
    helpers: list[str] = []
    if tree is not None:
        others = [block for block in blocks if block is not candidates[best]]
        sources, helpers = _missing_helpers(tree, others)
        if sources:
            chosen = "\n\n".join([*sources, chosen.rstrip("\n")]) + "\n"
    return ProgramChoice(chosen, len(blocks), helpers)


def extract_program(reply_text: str) -> str | None:
    """The program's source as the reply gives it (before demo code is dropped), or None."""
    choice = find_program(reply_text)
    return choice.source if choice else None


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
    intent: QuestionIntent,
    images_png: list[bytes],
    num_examples: int = 2,
    template_version: str = DEFAULT_TEMPLATE,
    attach_images: bool = True,
    rank_examples: bool = True,
) -> list[dict[str, Any]]:
    """The chat messages of the first code request: one user message, text then the photos.

    `attach_images=False` is for text-only code models: the prompt says how many photos exist and
    that the model does not see them, and the message is one plain string. `rank_examples=False`
    shows the examples in file order instead of those most like the question first.
    """
    template = load_template(template_version)
    count = len(images_png)
    photos = (
        f"There are {count} photo(s), shown below in order (image 1 first)."
        if attach_images
        else f"There are {count} photo(s). You do not see them: write the program from the question."
    )
    candidates: dict[str, object] = {
        "examples": _render_examples(num_examples, intent if rank_examples else None),
        "num_images": count,
        "photos": photos,
        "question": intent.text,
    }
    fields = {name: value for name, value in candidates.items() if name in template.fields}
    text = template.render(**fields)
    if not attach_images:
        return [{"role": "user", "content": text}]
    content: list[dict[str, Any]] = [text_part(text)]
    for index, png in enumerate(images_png, start=1):
        content.append(text_part(f"Image {index}:"))
        content.append(image_part(png))
    return [{"role": "user", "content": content}]


# ---- repair messages --------------------------------------------------------------------------------

_SHAPE_ERROR = re.compile(
    r"shapes \(\d|not aligned|matmul: Input operand|mismatch in its core dimension|could not be broadcast"
)
_HINTS: list[tuple[re.Pattern[str], str]] = [
    (
        _SHAPE_ERROR,
        "Extrinsics are 4x4 camera-from-world matrices [[R, t], [0, 0, 0, 1]] (x_cam = R @ x_world + t; "
        "camera x right, y down, z forward) and intrinsics are 3x3. A 3D point is a 3-vector: use "
        "R @ p + t, or E @ [x, y, z, 1] with a homogeneous point. Helpers: pySpatial.camera_center(E) "
        "(where a camera is), pySpatial.relative_pose(E1, E2), pySpatial.heading_angle(E1, E2) "
        "(degrees turned, + = left), pySpatial.distance_to_point(E, p).",
    ),
    (
        re.compile(r"Last 2 dimensions of the array must be square|LinAlgError"),
        "np.linalg.inv needs a square matrix: recon.extrinsics[i] is 4x4; for the pose of one view "
        "relative to another call pySpatial.relative_pose(E1, E2).",
    ),
    (
        re.compile(r"truth value of an array with more than one element is ambiguous"),
        "Comparing arrays gives an array: use np.allclose(a, b), or reduce with np.all(...) / np.any(...).",
    ),
    (
        re.compile(r"'Image' object is not (?:iterable|subscriptable)|Image' object has no attribute"),
        "pySpatial.synthesize_novel_view returns an image handle: the program cannot look inside it. "
        "Return the image (or a list of images) as the clue; another model looks at it.",
    ),
    (
        re.compile(r"typed (?:it|in) itself|not evidence"),
        "Do not decide the answer in the program. Return what the tools produce: the sentence of "
        "pySpatial.describe_camera_motion(recon), or views rendered with pySpatial.synthesize_novel_view.",
    ),
]


def repair_hints(error: str, kind: str | None = None, intent: QuestionIntent | None = None) -> list[str]:
    """The failure class's pointed hint (services/agent/repair_hints.py), then advice for mistakes
    code models are known to make, matched on the error text."""
    pointed = pointed_hints(error, kind, intent)
    return [*pointed, *(hint for pattern, hint in _HINTS if pattern.search(error) and hint not in pointed)]


def _cut(error: str) -> str:
    return error if len(error) <= _MAX_ERROR_CHARS else error[:_MAX_ERROR_CHARS] + " [...]"


def _repair_message(problem: str, detail: str, advice: list[str]) -> dict[str, Any]:
    template = load_template(REPAIR_TEMPLATE)
    hints = "\n".join(f"- {line}" for line in advice) if advice else "- Fix the cause of the error."
    return {"role": "user", "content": template.render(problem=problem, detail=detail, hints=hints)}


def _no_program_message(reply: ChatReply) -> dict[str, Any]:
    detail = "I need the code in a ```python block that defines `def program(input_scene):`."
    advice = []
    if reply.finish_reason == "length":
        advice.append("Your reply was cut off at the length limit: skip the explanation, send only the code.")
    return _repair_message("Your reply did not contain a program.", detail, advice)


# ---- the loop -----------------------------------------------------------------------------------


def _repair_temperature(base: float, repair: int, repeats: int) -> float:
    return min(MAX_TEMPERATURE, base + REPAIR_TEMPERATURE_STEP * (repair + repeats))


@dataclass
class _Loop:
    """What the repair loop has seen so far: the conversation, the attempts, the failed programs."""

    messages: list[dict[str, Any]]
    base_temperature: float
    intent: QuestionIntent | None = None
    attempts: list[Attempt] = field(default_factory=list)
    # fingerprint -> (attempt, error, error kind) of each program that ran and failed
    failed: dict[str, tuple[int, str, str | None]] = field(default_factory=dict)
    replies_without_program: set[str] = field(default_factory=set)
    repeats: int = 0
    runs: int = 0  # programs handed to `execute`
    repairing: int | None = None  # the failed run the next request shows the model
    last_error: str = "no attempt made"
    failure: Failure = "no_program"

    def temperature(self, number: int) -> float | None:
        """None (the model's own) for the first request; each repair and each repeat raise it."""
        return None if number == 1 else _repair_temperature(self.base_temperature, number - 1, self.repeats)

    def gives_up(self) -> bool:
        return self.repeats >= REPEATS_BEFORE_STOPPING  # more rounds would only cost time


def generate_program(
    client: ChatClient,
    intent: QuestionIntent,
    images_png: list[bytes],
    execute: Callable[[str], ExecutionOutcome | tuple],
    max_repairs: int = 2,
    num_examples: int = 2,
    template_version: str = DEFAULT_TEMPLATE,
    attach_images: bool = True,
    max_reply_chars: int = DEFAULT_MAX_REPLY_CHARS,
    log: SolveLog | None = None,
) -> CodegenResult:
    """Generate, run and repair a program; see the module docstring. Each request is a ProgramStep
    of `log` (the solve's records; a log of its own when none is given).

    Model failures (ModelUnavailable / ModelError) end the loop with `failure="model"`, the
    exception in `model_error` and the attempts made so far, so the caller can decide (fall back to
    the offline planner, or report a configuration error to the client).
    """
    if max_repairs < 0:
        raise ValueError(f"max_repairs must be >= 0, got {max_repairs}")
    messages = build_codegen_messages(intent, images_png, num_examples, template_version, attach_images)
    loop = _Loop(messages, client.config.temperature, intent)
    log = log or SolveLog()
    for number in range(1, max_repairs + 2):
        step = ProgramStep(attempt=number, author=client.config.model, repairs=loop.repairing)
        temperature = loop.temperature(number)
        with log.record(step):
            try:
                reply = client.complete(loop.messages, temperature=temperature)
            except LLMError as model_error:
                step.error, step.error_kind = str(model_error), "model"
                return CodegenResult(
                    ok=False,
                    attempts=loop.attempts,
                    error=str(model_error),
                    failure="model",
                    model_error=model_error,
                )
            attempt = _attempt(reply, loop.base_temperature if temperature is None else temperature)
            loop.attempts.append(attempt)
            step.program, follow_up = _read_reply(reply, attempt, loop, max_reply_chars)
            step.error, step.error_kind = (
                (attempt.error, attempt.error_kind) if step.program is None else (None, None)
            )
        if step.program is not None:
            result, follow_up = _run(step.program, number, execute, attempt, loop)
            if result is not None:
                return result
        else:
            loop.repairing = None
        if follow_up is None:
            break  # the model keeps sending the same reply
        loop.messages = [*loop.messages, {"role": "assistant", "content": attempt.reply}, follow_up]
    return CodegenResult(
        ok=False,
        attempts=loop.attempts,
        error=f"no working program after {len(loop.attempts)} attempt(s); last error: {loop.last_error}",
        failure=loop.failure,
    )


def _attempt(reply: ChatReply, temperature: float) -> Attempt:
    return Attempt(
        program=None,
        reply=reply.text,
        error=None,
        temperature=temperature,
        finish_reason=reply.finish_reason,
        prompt_tokens=reply.usage.prompt_tokens if reply.usage else None,
        completion_tokens=reply.usage.completion_tokens if reply.usage else None,
        latency_ms=reply.latency_ms,
    )


def _read_reply(
    reply: ChatReply, attempt: Attempt, loop: _Loop, max_reply_chars: int
) -> tuple[str | None, dict[str, Any] | None]:
    """(the program to run, None) or (None, the message asking again; None when the loop gives up)."""
    if len(reply.text) > max_reply_chars:
        return None, _too_long(reply, attempt, loop, max_reply_chars)
    choice = find_program(reply.text)
    if choice is None:
        return None, _without_program(reply, attempt, loop)
    cleaned = clean_program(choice.source)
    attempt.program, attempt.dropped = cleaned.source, cleaned.dropped
    earlier = loop.failed.get(program_fingerprint(cleaned.source))
    if earlier is not None:
        return None, _repeated(attempt, loop, *earlier)
    return cleaned.source, None


def _too_long(reply: ChatReply, attempt: Attempt, loop: _Loop, max_reply_chars: int) -> dict[str, Any]:
    attempt.reply = reply.text[:2000] + f"\n[... {len(reply.text) - 2000} more characters not kept]"
    attempt.error = loop.last_error = (
        f"the reply is {len(reply.text)} characters long; replies over {max_reply_chars} are not read"
    )
    attempt.error_kind, loop.failure = "too_long", "no_program"
    return _repair_message(
        "Your reply was far too long and was not read.",
        f"It had {len(reply.text)} characters; the limit is {max_reply_chars}.",
        ["Send only the program: one short ```python block defining `def program(input_scene):`."],
    )


def _without_program(reply: ChatReply, attempt: Attempt, loop: _Loop) -> dict[str, Any] | None:
    attempt.error = loop.last_error = "the reply contained no ```python block defining program()"
    attempt.error_kind, loop.failure = "no_program", "no_program"
    said = " ".join(reply.text.split())
    if said in loop.replies_without_program:
        loop.repeats += 1  # the same prose again: the model is going in circles
        if loop.gives_up():
            return None
    loop.replies_without_program.add(said)
    return _no_program_message(reply)


def _repeated(
    attempt: Attempt, loop: _Loop, earlier: int, earlier_error: str, earlier_kind: str | None
) -> dict[str, Any] | None:
    """An identical repair is not run again: the loop asks once more, naming the change, then moves on."""
    loop.repeats += 1
    attempt.error = loop.last_error = (
        f"the same program as attempt {earlier}, which failed: {_cut(earlier_error)} (not run again)"
    )
    attempt.error_kind, loop.failure = "repeated", "repeated"
    if loop.gives_up():
        return None
    hints = repair_hints(earlier_error, earlier_kind, loop.intent)
    return _repair_message(
        f"Your program is identical to attempt {earlier}, which failed; it was not run again. "
        "Send a program that differs from it where the hints below say.",
        f"Attempt {earlier} failed with:\n{_cut(earlier_error)}",
        [*hints, "The program you sent is unchanged: change at least the line the first hint names."]
        if hints
        else ["Change the code that raises the error; do not send the same program."],
    )


def _run(
    program: str, number: int, execute: Callable, attempt: Attempt, loop: _Loop
) -> tuple[CodegenResult | None, dict[str, Any]]:
    """(the result, when the program worked) or (None, the repair message with its error)."""
    loop.runs += 1
    started = time.perf_counter()
    outcome = execute(program)
    attempt.execution_ms = (time.perf_counter() - started) * 1000.0
    ok, error, payload = outcome[0], outcome[1], outcome[2]
    if ok:
        return CodegenResult(ok=True, program=program, payload=payload, attempts=loop.attempts), {}
    error = error or "the program failed without an error message"
    attempt.error = loop.last_error = error
    attempt.error_kind = outcome[3] if len(outcome) > 3 and outcome[3] else "execution"
    loop.failure = "execution"
    if attempt.error_kind in FINAL_ERROR_KINDS:
        failed = f"no working program after {len(loop.attempts)} attempt(s); the solve stopped: {error}"
        return CodegenResult(ok=False, attempts=loop.attempts, error=failed, failure="budget"), None
    loop.failed[program_fingerprint(program)] = (number, error, attempt.error_kind)
    loop.repairing = loop.runs
    hints = repair_hints(error, attempt.error_kind, loop.intent)
    problem = _PROBLEMS.get(attempt.error_kind or "", "Your program failed.")
    return None, _repair_message(problem, f"Error:\n{_cut(error)}", hints)


# What the repair request says first, per failure class (the hints then name the fix).
_PROBLEMS = {
    "wrong_view": "Your program ran, but its clue is about other views than the question asks.",
    "no_motion": "Your program ran, but its clue does not say how the camera moved between the views.",
    "answer_letter": "Your program returned an answer instead of a clue.",
    "not_evidence": "Your program returned text it wrote itself instead of a tool's output.",
    "empty_clue": "Your program returned an empty clue.",
    "unread_images": "Your program returned only images, and nothing here can look at images.",
    "rejected": "Your program was rejected before it ran.",
    "timeout": "Your program ran out of time.",
}


__all__ = [
    "Attempt",
    "CodegenResult",
    "ExecutionOutcome",
    "ProgramChoice",
    "build_codegen_messages",
    "extract_program",
    "find_program",
    "generate_program",
    "repair_hints",
]
