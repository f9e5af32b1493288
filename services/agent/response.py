"""The response of a solve, made from its step records and what the stages produced."""

from __future__ import annotations

from services.agent.stages.clue import ClueReading
from services.agent.stages.program import WrittenProgram
from services.agent.steps import SolveLog
from shared.questions.intent import QuestionIntent
from shared.wire.schemas import (
    AnswerStep,
    ExecutionStep,
    ProgramStep,
    ReconstructionStep,
    SceneStep,
    SolveResponse,
    SolveTimings,
    TokenCounts,
)

IMAGES_ONLY = "images_only"


def respond(
    log: SolveLog,
    intent: QuestionIntent,
    scene: SceneStep,
    recon: ReconstructionStep,
    written: WrittenProgram,
    answer: AnswerStep,
    reading: ClueReading | None = None,
    fallback_reason: str | None = None,
) -> SolveResponse:
    """`fallback_reason`: why the answer came from the photos alone (images_only when a model gave it)."""
    answered = answer.answer is not None
    return SolveResponse(
        answer=answer.answer,
        answer_format=answer.answer_format,
        answer_reason=None if answered else answer.error,
        reasoning=answer.reasoning,
        program=written.program,
        clue=(reading or ClueReading()).clue,
        attempts=written.attempts,
        scene_id=scene.scene_id or "",
        backbone=recon.backbone or "",
        code_model=written.code_model,
        code_model_fallback=written.fallback,
        program_source=written.source if written.program is not None else None,
        answer_model=answer.answered_by or "",
        answer_method=answer.method if answered else None,
        tokens=TokenCounts(
            code_prompt=sum(attempt.prompt_tokens or 0 for attempt in written.attempts),
            code_completion=sum(attempt.completion_tokens or 0 for attempt in written.attempts),
            answer_prompt=answer.prompt_tokens,
            answer_completion=answer.completion_tokens,
        ),
        fallback=IMAGES_ONLY if answer.from_photos and answer.answerer is not None else None,
        fallback_reason=fallback_reason,
        intent=intent,
        reading=intent.reading,
        timings=timings(log),
        steps=[step.model_dump() for step in log.steps],
    )


def timings(log: SolveLog) -> SolveTimings:
    """Per stage, the time of its steps (all requests to the code model, all sandbox runs)."""
    return SolveTimings(
        reconstruction_ms=log.total_ms(ReconstructionStep),
        codegen_ms=log.total_ms(ProgramStep),
        execution_ms=log.total_ms(ExecutionStep),
        answering_ms=log.total_ms(AnswerStep),
        total_ms=log.elapsed_ms(),
    )


__all__ = ["IMAGES_ONLY", "respond", "timings"]
