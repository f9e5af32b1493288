"""The answer: from the clue of the program that ran, or from the photos alone when none ran.

From the clue: a vision answer model reads the photos, the program and its output; a text-only one
reads text clues only; without an answer model the offline rules read camera-motion sentences, and a
(text) code model reads the text clue they cannot. From the photos alone (as the paper's code does)
only with an answer model; otherwise the answer is null with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass

from services.agent.answer_result import AnswerResult
from services.agent.answering import (
    VISION_MODEL_HINT,
    answer_from_images,
    answer_offline,
    answer_text_clue_with_model,
    answer_with_model,
)
from services.agent.claim_matching import read_by_claims
from services.agent.free_form import answer_format
from services.agent.llm import ChatClient
from services.agent.stages.clue import ClueReading
from services.agent.stages.program import WrittenProgram
from shared.questions.intent import QuestionIntent
from shared.wire.schemas import AnswerStep, ExecutionStep

OFFLINE_ANSWERER = "offline-answerer"
NEEDS_ANSWER_MODEL = "answering from the photos alone needs an answer model (PYSPATIAL_ANSWER_MODEL)"


@dataclass
class Answerers:
    """The models that may answer: `answer` (vision, or text-only), and `code` for text clues."""

    answer: ChatClient | None
    answer_text_only: bool
    code: ChatClient | None

    @property
    def answer_name(self) -> str:
        return self.answer.config.model if self.answer is not None else OFFLINE_ANSWERER


def from_clue(
    step: AnswerStep,
    answerers: Answerers,
    intent: QuestionIntent,
    photos: list[bytes],
    written: WrittenProgram,
    reading: ClueReading,
) -> AnswerStep:
    """The answer to the clue of the program that ran (null with the reason when none ran)."""
    step.answer_format = answer_format(intent)
    run, program = written.run, written.program
    if run is None or program is None:
        reason = f"no program ran successfully: {written.failure}; {NEEDS_ANSWER_MODEL}"
        return _fill(step, AnswerResult(answer=None, method="none", reason=reason), answerers.answer_name)
    if answerers.answer is not None:
        result, name = _answer_model(answerers, intent, photos, program, run, reading)
    else:
        result, name = _offline(
            answerers, intent, program, run, reading, code_failed=written.fallback is not None
        )
    return _fill(step, result, name)


def from_photos(
    step: AnswerStep, answerers: Answerers, intent: QuestionIntent, photos: list[bytes], why: str
) -> AnswerStep:
    """No program ran: the answer model answers from the photos alone; without one, null and why."""
    step.answer_format = answer_format(intent)
    if answerers.answer is None:
        result = AnswerResult(answer=None, method="none", reason=f"{why}; {NEEDS_ANSWER_MODEL}")
    else:
        result = answer_from_images(answerers.answer, intent, photos)
    return _fill(step, result, answerers.answer_name)


def _answer_model(
    answerers: Answerers,
    intent: QuestionIntent,
    photos: list[bytes],
    program: str,
    run: ExecutionStep,
    reading: ClueReading,
) -> tuple[AnswerResult, str]:
    """The answer model's answer (vision, or text-only), and its name as the response gives it."""
    client, name = answerers.answer, answerers.answer_name
    if not answerers.answer_text_only:
        full_text = "\n".join(filter(None, [reading.text, *reading.notes])) or None
        return answer_with_model(client, intent, photos, program, full_text, run.clue_pngs), name
    if reading.text:  # a text-only answer model: it reads text clues and nothing else
        return answer_text_clue_with_model(client, intent, program, reading.text), f"{name} (text only)"
    reason = (
        f"the answer model {name!r} is text-only and the clue is {run.clue_images} rendered "
        f"view(s): {VISION_MODEL_HINT}"
    )
    return AnswerResult(answer=None, method="none", reason=reason), name


def _offline(
    answerers: Answerers,
    intent: QuestionIntent,
    program: str,
    run: ExecutionStep,
    reading: ClueReading,
    code_failed: bool,
) -> tuple[AnswerResult, str]:
    """The offline rules' answer; a (text) code model reads the text clue they cannot read."""
    offline = answer_offline(intent, reading.text, run.clue_pngs)
    if offline.answer is not None or not reading.text or answerers.code is None or code_failed:
        return offline, OFFLINE_ANSWERER
    if read_by_claims(intent, reading.text):
        # A camera question whose clue states the motion: the reading and the sentence decided, and
        # their doubt (undetermined, two readings, an unread option) is the answer; no model guesses.
        return offline, OFFLINE_ANSWERER
    # Only a (text) code model is configured and the offline rules could not read the text clue.
    code_name = answerers.code.config.model
    answer = answer_text_clue_with_model(answerers.code, intent, program, reading.text)
    if answer.answer is None:
        reason = f"{offline.reason}; the text model {code_name!r} gave none either: {answer.reason}"
        return answer.model_copy(update={"reason": reason}), OFFLINE_ANSWERER
    return answer, f"{code_name} (text only)"


def _fill(step: AnswerStep, result: AnswerResult, answered_by: str) -> AnswerStep:
    step.answer, step.method, step.reasoning = result.answer, result.method, result.reasoning
    step.prompt_tokens, step.completion_tokens = result.prompt_tokens, result.completion_tokens
    step.error = result.reason if result.answer is None else None
    step.answered_by = answered_by
    return step


__all__ = ["OFFLINE_ANSWERER", "Answerers", "from_clue", "from_photos"]
