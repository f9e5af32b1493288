"""Free-form questions: a question without lettered options is answered in words, marked as such.

The one place for the mechanism (the answerers in answering.py call it when the question has no
options):
- `answer_format(intent)`: "choice" when the question has options, else "free_form"; the response
  and the answer step carry it, so a client knows whether `answer` is a letter or words;
- the prompts a model is asked with: the free-form twin of each answer prompt (`template_for`),
  which asks for a short phrase instead of a letter;
- `read_reply`: a model's free-form reply (its JSON `answer`, else its whole text);
- `answer_offline`: without a model, the camera-motion sentence about the asked pair of views, said
  in its direction and turn words (`motion_in_words`); otherwise a null answer with the reason.
  `motion_in_words` is where the offline vocabulary lives: extend it there.
"""

from __future__ import annotations

import re
from typing import Literal

from services.agent.answer_result import AnswerResult, json_object, no_answer
from services.agent.asked_frame import frame_refusal
from services.agent.claim_matching import pick_pair_statement, question_reading
from services.agent.motion_clue import (
    NO_GRAVITY_OVER_FOCAL,
    UNDETERMINED,
    MotionStatement,
    OverFocal,
    hypothetical_readings,
    motion_statements,
    not_a_motion_question,
    step_size,
    unreadable_clue,
)
from shared.questions.intent import QuestionIntent
from shared.questions.motion_words import AskedMotion, Frame, MotionReading

AnswerFormat = Literal["choice", "free_form"]
CHOICE: AnswerFormat = "choice"
FREE_FORM: AnswerFormat = "free_form"

# Each multiple-choice answer prompt and its free-form twin (services/agent/prompts/).
_TWINS = {
    "answer_v1": "answer_free_form_v1",
    "answer_text_v1": "answer_free_form_text_v1",
    "answer_images_only_v1": "answer_free_form_images_only_v1",
}


def answer_format(intent: QuestionIntent) -> AnswerFormat:
    return CHOICE if intent.options else FREE_FORM


def is_free_form(intent: QuestionIntent) -> bool:
    return answer_format(intent) == FREE_FORM


def template_for(intent: QuestionIntent, template: str) -> str:
    """The prompt to ask with: `template`, or its free-form twin when the question has no options."""
    if not is_free_form(intent):
        return template
    if template not in _TWINS:
        raise ValueError(f"the answer prompt {template!r} has no free-form twin")
    return _TWINS[template]


def read_reply(text: str) -> AnswerResult:
    """A model's answer to a free-form question: its JSON `answer`, else the whole reply."""
    data = json_object(text)
    if data is not None and str(data.get("answer") or "").strip():
        reasoning = str(data.get("reasoning") or "")
        return AnswerResult(
            answer=str(data["answer"]).strip(), reasoning=reasoning, raw=text, method="model_json"
        )
    if data is not None and "answer" in data:
        reason = "the answer model gave an empty answer: " + str(data.get("reasoning") or "")[:300]
        return AnswerResult(
            answer=None, reasoning=str(data.get("reasoning") or ""), raw=text, method="none", reason=reason
        )
    if text.strip():
        return AnswerResult(answer=text.strip(), reasoning="", raw=text, method="model_free_text")
    return AnswerResult(answer=None, raw=text, method="none", reason="the answer model's reply was empty")


def answer_offline(intent: QuestionIntent, clue_text: str | None, clue_images: list[bytes]) -> AnswerResult:
    """The camera-motion sentence about the asked pair, in words; else None with the reason."""
    text = (clue_text or "").strip()
    statements = motion_statements(text) if text else []
    if not statements:
        return no_answer(unreadable_clue(text, clue_images))
    reading = question_reading(intent)
    why = not_a_motion_question(intent, reading)
    if why is not None:
        return no_answer(why)
    statement, why = pick_pair_statement(reading, statements)
    if statement is None:
        return no_answer(why)
    said = {"turn"} if intent.asks_turn_only else {"direction", "vertical", "turn", "tilt", "roll"}
    if (refused := frame_refusal(reading, statement, said, end_step_used=False)) is not None:
        return no_answer(f"{refused} ({reading.summary})")
    if statement.over_focal is not None:
        if intent.motion_frame == "gravity":
            return no_answer(f"{UNDETERMINED}: {NO_GRAVITY_OVER_FOCAL}")
        return _over_focal_in_words(statement, intent.motion_asked)
    words = motion_in_words(statement, intent.asks_turn_only, intent.motion_frame)
    if words is None:
        return no_answer(f"the offline answerer finds no direction or turn in {statement.sentence!r}")
    return AnswerResult(
        answer=words,
        reasoning=f"The program's output says: {statement.sentence!r}.",
        method="offline_text",
    )


# What a free-form answer over focal hypotheses says, per asked motion (intent.motion_asked).
_SAID_FOR = {
    "turn": ("turn",),
    "tilt": ("tilt",),
    "roll": ("roll",),
    "move": ("step", "turn", "tilt", "roll"),
    "any": ("step", "turn", "tilt", "roll"),
}


def _over_focal_in_words(statement: MotionStatement, asked: AskedMotion) -> AnswerResult:
    """Only what holds at every focal hypothesis; the rest is said to be undetermined, with its range."""
    over = statement.over_focal
    assert over is not None
    said, open_ = [], []
    for quantity in _SAID_FOR[asked]:
        words = _determined_words(over, quantity)
        if words is None:
            open_.append(f"the {quantity} {UNDETERMINED}: {_range_words(over, quantity)}")
        elif words or quantity == _SAID_FOR[asked][0]:
            said.append(words or _NONE_WORDS[quantity])
    if not said:
        return no_answer(f"{UNDETERMINED}: {statement.sentence}")
    answer = ", ".join(said) + (f" ({'; '.join(open_)})" if open_ else "")
    return AnswerResult(
        answer=answer,
        reasoning=f"The program's output says: {statement.sentence!r}; this holds at every focal length.",
        method="offline_text",
    )


_NONE_WORDS = {
    "step": "stayed in place",
    "turn": "did not turn significantly",
    "tilt": "did not tilt significantly",
    "roll": "did not roll significantly",
}


_MARK = re.compile(r" \(not determined(?:; (heading [^,]+), 0 = forward, \+ = left)?\)")


def _range_words(over: OverFocal, quantity: str) -> str:
    """'moved forward or diagonally forward and left, heading 0 to 45 degrees': a clause without its mark."""
    clause = over.clauses.get(quantity, "the sentence does not state it").removeprefix("it ")
    return _MARK.sub(
        lambda found: f", {found.group(1)} (0 = forward, + = left)" if found.group(1) else "", clause
    )


def _determined_words(over: OverFocal, quantity: str) -> str | None:
    """One quantity's words when every hypothesis agrees ("" when they agree it is none), else None."""
    if quantity == "step":
        readings = hypothetical_readings(over, keys=("direction", "vertical"), degrees=False)
        steps = {(v.reading.direction, v.reading.vertical) for v in readings}
        if len(steps) != 1:
            return None
        ways = [way for way in steps.pop() if way]
        return f"moved {' and '.join(ways)}" if ways else ""
    readings = hypothetical_readings(over, quantity, keys=(quantity,), degrees=False)  # type: ignore[arg-type]
    words = {getattr(v.reading, quantity) for v in readings}
    if len(words) != 1:
        return None
    word = words.pop()
    if word in (None, "no turn", "no tilt"):
        return ""
    verb, side = str(word).split(" ", 1)
    ends = {"turn": over.yaw_range_deg, "tilt": over.tilt_range_deg, "roll": over.roll_range_deg}[quantity]
    if ends is None or side == "around":
        return f"{verb}ed {side}"
    low, high = sorted(abs(end) for end in ends)
    span = f"about {high:g}" if low == high else f"{low:g} to {high:g}"
    return f"{verb}ed {side} by {span} degrees"


def motion_in_words(statement: MotionStatement, asks_turn_only: bool, frame: Frame = "image") -> str | None:
    """'moved down (about 0.09 scene units), tilted up by about 8 degrees', 'stayed still', ... or None.

    Read through the one vocabulary (shared.questions.motion_words), in the frame the question
    means; None when the sentence states no motion these words cover.
    """
    if asks_turn_only:
        return _turn_words(statement, alone=True)
    reading = statement.reading_for(frame)
    clause = statement.gravity_clause if reading is statement.gravity else statement.main_clause
    clause = clause or statement.sentence
    if reading.still:
        return "stayed still"
    rotations = [_angle_words(clause, kind, value) for kind, value in _rotations(reading)]
    moved = _step_words(reading, clause)
    if moved is None and not rotations:
        return None
    parts = [moved or "stayed in place", *rotations]
    if not rotations:
        parts.append("without turning significantly")
    if reading.target is not None:
        parts.append(
            "came closer to the target" if reading.target == "closer" else "moved farther from the target"
        )
    return ", ".join(parts)


def _rotations(reading: MotionReading) -> list[tuple[str, str]]:
    found = []
    if reading.turn not in (None, "no turn"):
        found.append(("turned", str(reading.turn).removeprefix("turn ")))
    if reading.tilt not in (None, "no tilt"):
        found.append(("tilted", str(reading.tilt).removeprefix("tilt ")))
    if reading.roll is not None:
        found.append(("rolled", reading.roll.removeprefix("roll ")))
    return found


def _angle_words(clause: str, verb: str, side: str) -> str:
    """'tilted up by about 8 degrees': the angle the clause states next to that word, when it does."""
    stated = re.search(rf"\b{side}\b[^,;.]*?(\d+(?:\.\d+)?)\s*(?:°|degrees?\b)", clause, re.IGNORECASE)
    about = f" by about {float(stated.group(1)):g} degrees" if stated else ""
    return f"{verb} {side}{about}"


def _step_words(reading: MotionReading, clause: str) -> str | None:
    ways = [way for way in (reading.direction, reading.vertical) if way]
    if not ways:
        return None
    size = step_size(clause)
    return f"moved {' and '.join(ways)}" + (f" (about {size})" if size else "")


def _turn_words(statement: MotionStatement, alone: bool) -> str | None:
    if statement.turn is None:
        return None
    if statement.turn == "no turn":
        return "did not turn significantly" if alone else "without turning significantly"
    if statement.turn == "turn around":
        return "turned around"
    side = statement.turn.removeprefix("turn ")
    about = f" by about {statement.degrees:g} degrees" if statement.degrees is not None else ""
    return f"turned {side}{about}"


__all__ = [
    "CHOICE",
    "FREE_FORM",
    "AnswerFormat",
    "answer_format",
    "answer_offline",
    "is_free_form",
    "motion_in_words",
    "read_reply",
    "template_for",
]
