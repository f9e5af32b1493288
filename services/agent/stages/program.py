"""A program for the question, run in the sandbox and repaired when it fails.

With a code model: codegen's repair loop (one ProgramStep per request, one ExecutionStep per run).
Without one, or when the model cannot be reached even after retries, or when its attempts run out:
the offline planner writes the program from the intent, and the result says who wrote it and why.
Not when the solve's CPU budget stopped the attempts: nothing may run past it. A model that refuses our key or
our messages is a configuration error (502 to the client): a fallback would hide it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from services.agent.codegen import Attempt, generate_program
from services.agent.errors import SolveError
from services.agent.llm import ChatClient, ModelConfigurationError
from services.agent.planner import PlanningError, UnplannableQuestion, plan_intent
from services.agent.sandbox.text import clean_text
from services.agent.stages.execution import SandboxRuns
from shared.wire.schemas import AttemptRecord, ExecutionStep, ProgramSource, ProgramStep
from shared.wire.settings import AgentSettings

log = logging.getLogger("pyspatial.agent")

OFFLINE_PLANNER = "offline-planner"


@dataclass
class WrittenProgram:
    """What the program stage produced: the attempts, and the run that worked (or why none did)."""

    code_model: str  # what wrote the program (the response's `code_model`)
    attempts: list[AttemptRecord] = field(default_factory=list)
    program: str | None = None  # the program that ran successfully
    run: ExecutionStep | None = None  # its run
    failure: str | None = None  # why no program ran successfully
    fallback: str | None = None  # why the code model did not write it (the planner did)
    by_model: bool = False  # the code model wrote it (its output is checked for typed-in claims)
    source: ProgramSource | None = None  # who wrote the program that ran (None: none ran)


def write_and_run(
    runs: SandboxRuns,
    photos: list[bytes],
    code_client: ChatClient | None,
    settings: AgentSettings,
    max_repairs: int | None,
) -> WrittenProgram:
    """The program stage: the code model's (repaired) program, else the offline planner's."""
    if code_client is None:
        return plan_offline(runs, OFFLINE_PLANNER)
    generated = generate_program(
        code_client,
        runs.intent,
        photos,
        runs.execute,
        max_repairs=settings.max_repairs if max_repairs is None else max_repairs,
        num_examples=settings.num_examples,
        attach_images=not settings.code_model_text_only,
        max_reply_chars=settings.max_reply_chars,
        log=runs.log,
    )
    attempts = [_attempt_record(attempt) for attempt in generated.attempts]
    name = code_client.config.model
    if generated.failure == "model":
        if isinstance(generated.model_error, ModelConfigurationError):
            # A rejected key or a server that cannot take our messages: an operator must fix a
            # setting, and a fallback would hide that. The client gets a 502 saying what to fix.
            raise generated.model_error
        # The model could not be reached even after retries: the planner still gives an honest
        # result, and the response says who wrote the program and why.
        log.warning("code model failed (%s); falling back to the offline planner", generated.error)
        planned = plan_offline(runs, f"{OFFLINE_PLANNER} (fallback: {name} failed)", attempts, fallback=True)
        planned.fallback = f"{name} failed: {generated.error}"
        return planned
    if generated.failure == "budget":
        # The solve's CPU budget is spent: the planner's program would be refused unrun too, and the
        # failure (the answer's fallback_reason) names the budget that stopped the solve.
        return WrittenProgram(name, attempts, failure=attempts[-1].error, by_model=True)
    if generated.ok:
        source: ProgramSource = "repaired-model" if len(generated.attempts) > 1 else "model"
        program = _encodable(generated.program)
        return WrittenProgram(name, attempts, program, generated.payload, by_model=True, source=source)
    failure = attempts[-1].error if attempts else "no program was produced"
    return _planner_after_the_model(runs, name, attempts, failure)


def _planner_after_the_model(
    runs: SandboxRuns, name: str, attempts: list[AttemptRecord], failure: str
) -> WrittenProgram:
    """The model's attempts ran out: the planner's program when it has one, labelled as the planner's
    (the model's attempts stay in the record); else the model's failure, with the planner's reason."""
    why = f"{name}'s {len(attempts)} attempt(s) failed; last error: {failure}"
    planned = plan_offline(runs, f"{OFFLINE_PLANNER} (fallback: {name} failed)", attempts, fallback=True)
    if planned.program is None:
        failure = f"{failure} (and {planned.failure})"
        return WrittenProgram(name, planned.attempts, failure=failure, by_model=True)
    log.info("code model's attempts ran out; the offline planner's program ran (%s)", why)
    planned.fallback = why
    return planned


def plan_offline(
    runs: SandboxRuns, code_model: str, attempts: list[AttemptRecord] | None = None, fallback: bool = False
) -> WrittenProgram:
    """The offline planner's program for the intent, run once (it is not repaired). `fallback`: after
    the code model's attempts (the step and the response say so)."""
    attempts = list(attempts or [])
    step = ProgramStep(attempt=len(attempts) + 1, author=OFFLINE_PLANNER, fallback=fallback)
    with runs.log.record(step):
        try:
            step.program = plan_intent(runs.intent, runs.num_images).source
        except PlanningError as error:  # e.g. the question names image 5 of 3
            raise SolveError(422, f"cannot plan a program for this question: {error}") from error
        except UnplannableQuestion as unplannable:
            step.error = f"the offline planner has no program for this question: {unplannable.reason}"
            step.error_kind = "unplannable"
    if step.program is None:
        return WrittenProgram(code_model, attempts, failure=step.error)  # unplannable
    outcome = runs.execute(step.program, written_by_model=False)
    run: ExecutionStep = outcome.payload
    attempts.append(
        AttemptRecord(
            program=step.program,
            error=outcome.error,
            reply=None,
            latency_ms=run.duration_ms,
            error_kind=outcome.error_kind,
        )
    )
    if outcome.ok:
        return WrittenProgram(code_model, attempts, step.program, run, source="planner")
    return WrittenProgram(code_model, attempts, failure=outcome.error)


def _attempt_record(attempt: Attempt) -> AttemptRecord:
    return AttemptRecord(
        program=_encodable(attempt.program),
        error=_encodable(attempt.error),
        reply=_encodable(attempt.reply),
        latency_ms=round(attempt.latency_ms, 2),
        error_kind=attempt.error_kind,
        dropped=attempt.dropped,
        temperature=attempt.temperature,
        prompt_tokens=attempt.prompt_tokens,
        completion_tokens=attempt.completion_tokens,
    )


def _encodable(text: str | None) -> str | None:
    """A model's text in the response: lone surrogates (valid in JSON, not in UTF-8) replaced."""
    return None if text is None else clean_text(text)


__all__ = ["OFFLINE_PLANNER", "WrittenProgram", "plan_offline", "write_and_run"]
