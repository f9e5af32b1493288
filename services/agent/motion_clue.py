"""Camera-motion sentences in a program's text output, and the one about the pair a question asks.

"From view 1 to view 2 the camera moved diagonally forward and right and turned left by about 45
degrees." becomes a `MotionStatement` (pair, direction, turn, degrees), wording normalized by
shared.questions.choices. Both offline answerers read them: the multiple-choice one compares them
with the options (answering.py), the free-form one says them in words (free_form.py).
"""

from __future__ import annotations

import re

from pydantic import BaseModel

from shared.questions.choices import normalize_direction, normalize_turn, turn_degrees
from shared.questions.intent import QuestionIntent
from shared.questions.motion_words import Frame, MotionReading, read_motion

VISION_MODEL_HINT = (
    "set PYSPATIAL_ANSWER_MODEL (and PYSPATIAL_ANSWER_MODEL_BASE_URL, PYSPATIAL_ANSWER_MODEL_API_KEY) "
    "to a vision-capable chat model"
)
_PAIR = re.compile(r"\b(?:view|image)\s+(\d+)\b.*?\b(?:view|image)\s+(\d+)\b", re.IGNORECASE)
_SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z])")
_MOVED_OR_NOT = re.compile(
    r"\b(?:moved|stayed in place|stayed still|neither moved|tilted|rolled)\b", re.IGNORECASE
)
_GRAVITY_CLAUSE = re.compile(r"^in the scene'?s gravity frame (?:it )?", re.IGNORECASE)
_TARGET_CLAUSE = re.compile(r"^it (?:came closer to|moved farther from|stayed as far from)\b", re.IGNORECASE)
_STEP = re.compile(r"\b(?:a step of )?(\d+(?:\.\d+)?) ?(m|scene units)\b")


class MotionStatement(BaseModel):
    pair: tuple[int, int] | None
    sentence: str
    direction: str | None  # one of shared.questions.choices.DIRECTIONS, None when it did not move
    turn: str | None  # "turn left", "turn right", "turn around", "no turn", or None
    degrees: float | None
    reading: MotionReading | None = None  # the whole vocabulary, in the sentence's first frame (image)
    gravity: MotionReading | None = None  # the scene's gravity frame, when the sentence gives it apart
    main_clause: str = ""  # the first frame's words, for free-form answers
    gravity_clause: str | None = None

    def reading_for(self, frame: Frame) -> MotionReading:
        """The reading in the frame the question means (its intent's `motion_frame`)."""
        if frame == "gravity" and self.gravity is not None:
            return self.gravity
        return self.reading or read_motion(self.sentence)


def _clauses(sentence: str) -> tuple[str, str | None, str | None]:
    """(the first frame's clause, the gravity frame's, the target's) of one motion sentence."""
    main, gravity, target = "", None, None
    for position, clause in enumerate(part.strip() for part in sentence.rstrip(".").split(";")):
        if position and _GRAVITY_CLAUSE.match(clause):
            gravity = _GRAVITY_CLAUSE.sub("", clause)
        elif position and _TARGET_CLAUSE.match(clause):
            target = clause
        else:
            main = f"{main}; {clause}" if main else clause
    return main, gravity, target


def _with_target(reading: MotionReading, target: str | None) -> MotionReading:
    if target is None:
        return reading
    return reading.model_copy(update={"target": read_motion(target).target})


def motion_statements(clue_text: str) -> list[MotionStatement]:
    statements = []
    for line in clue_text.splitlines():
        for sentence in _SENTENCE_END.split(line.strip()):
            main, gravity, target = _clauses(sentence)
            direction, turn = normalize_direction(main), normalize_turn(main)
            if direction is None and turn is None and not _MOVED_OR_NOT.search(main):
                continue
            pair_match = _PAIR.search(sentence)
            pair = (int(pair_match.group(1)), int(pair_match.group(2))) if pair_match else None
            statements.append(
                MotionStatement(
                    pair=pair,
                    sentence=sentence.strip(),
                    direction=direction,
                    turn=turn,
                    degrees=turn_degrees(main),
                    reading=_with_target(read_motion(main), target),
                    gravity=_with_target(read_motion(gravity), target) if gravity else None,
                    main_clause=main,
                    gravity_clause=gravity,
                )
            )
    return statements


def step_size(clause: str) -> str | None:
    """The step's size a clause states ('0.09 scene units', '0.42 m'), or None."""
    found = _STEP.search(clause)
    return f"{found.group(1)} {found.group(2)}" if found else None


def pick_statement(
    intent: QuestionIntent, statements: list[MotionStatement]
) -> tuple[MotionStatement | None, str]:
    """The statement about the pair the question asks for (from its parsed intent), or None and why."""
    named = len(intent.mentioned_views) >= 2
    if intent.motion_pair is not None and (named or len(statements) > 1):
        for statement in statements:
            if statement.pair == intent.motion_pair:
                return statement, ""
        first, second = intent.motion_pair
        return None, f"the program's output has no sentence about view {first} to view {second}"
    if len(statements) == 1:
        return statements[0], ""
    return None, "the question does not say which pair of views it asks about"


def not_a_motion_question(intent: QuestionIntent) -> str | None:
    """Why a motion sentence cannot answer this question (None when it can)."""
    if intent.family == "self_movement":
        return None
    return (
        "the program's output describes camera motion, but this is a "
        f"{intent.family.replace('_', ' ')} question, which a motion sentence does not answer"
    )


def unreadable_clue(text: str, clue_images: list[bytes]) -> str:
    """Why the offline answerer cannot read a clue that holds no camera-motion sentence it can use."""
    if clue_images:
        count = len(clue_images)
        return (
            f"the clue is {count} rendered view{'s' if count != 1 else ''}; answering from images "
            f"needs a vision model: {VISION_MODEL_HINT}"
        )
    if text:
        return (
            "the offline answerer only reads camera-motion sentences, and the program's output "
            f"is not one: {text[:200]!r}"
        )
    return "the program produced no clue (no text, no images)"


__all__ = [
    "VISION_MODEL_HINT",
    "MotionStatement",
    "unreadable_clue",
    "motion_statements",
    "not_a_motion_question",
    "pick_statement",
    "step_size",
]
