"""Camera-motion sentences in a program's text output, and the one about the pair a question asks.

"From view 1 to view 2 the camera moved diagonally forward and right and turned left by about 45
degrees." becomes a `MotionStatement` (pair, direction, turn, degrees), wording normalized by
shared.questions.choices. Both offline answerers read them: the multiple-choice one compares them
with the options (answering.py), the free-form one says them in words (free_form.py).
"""

from __future__ import annotations

import math
import re

import numpy as np
from pydantic import BaseModel

from shared.geometry.camera_motion import describe_turn, direction_name
from shared.questions.choices import normalize_direction, normalize_turn, turn_degrees
from shared.questions.intent import QuestionIntent
from shared.questions.motion_words import Frame, MotionReading, read_motion

VISION_MODEL_HINT = (
    "set PYSPATIAL_ANSWER_MODEL (and PYSPATIAL_ANSWER_MODEL_BASE_URL, PYSPATIAL_ANSWER_MODEL_API_KEY) "
    "to a vision-capable chat model"
)
# What the offline answerers say when the motion differs between the focal lengths the photos allow.
UNDETERMINED = "cannot be determined from these photos"
_PAIR = re.compile(r"\b(?:view|image)\s+(\d+)\b.*?\b(?:view|image)\s+(\d+)\b", re.IGNORECASE)
_SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z])")
_MOVED_OR_NOT = re.compile(
    r"\b(?:moved|stayed in place|stayed still|neither moved|tilted|rolled)\b", re.IGNORECASE
)
_GRAVITY_CLAUSE = re.compile(r"^in the scene'?s gravity frame (?:it )?", re.IGNORECASE)
_TARGET_CLAUSE = re.compile(r"^it (?:came closer to|moved farther from|stayed as far from)\b", re.IGNORECASE)
_STEP = re.compile(r"\b(?:a step of )?(\d+(?:\.\d+)?) ?(m|scene units)\b")


class OverFocal(BaseModel):
    """What a sentence over an unknown focal allows (motion_determinacy.determinacy_sentence)."""

    directions: list[str | None]  # every step direction some hypothesis gives; None = stayed in place
    yaw_range_deg: tuple[float, float] | None  # signed, + = left; None: no significant turn throughout
    heading_range_deg: tuple[float, float] | None = None  # of the step: 0 forward, + right


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

    over_focal: OverFocal | None = None  # set for a motion over focal hypotheses (then the above are None)
    heading_deg: float | None = None  # of the step, 0 forward, + right: set on hypothetical statements

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


def _no_turn_unless_named(reading: MotionReading) -> MotionReading:
    """A clause that lists its rotations (a tilt, a roll) without a turn did not turn significantly.

    shared/geometry/camera_motion.py names every rotation over its threshold, and says "without
    turning significantly" only when there is none at all: "moved down, and tilted up by about 20
    degrees" is no turn, as a question that asks about turning (templeRing's views 1 and 2) needs.
    """
    rotated = reading.tilt not in (None, "no tilt") or reading.roll is not None
    if reading.turn is None and rotated:
        return reading.model_copy(update={"turn": "no turn"})
    return reading


# "... the camera turned left by 12 to 42 degrees (determined) and moved forward or ... (not determined),"
_OVER_FOCAL = re.compile(
    r"the camera (?P<turn>.+?) \((?:not )?determined\) and (?P<move>.+?) \((?:not )?determined"
    r"(?:; heading (?P<low>-?\d+) to (?P<high>-?\d+) degrees[^)]*)?\)"
)
_TURN_SPAN = re.compile(r"turned (left|right) by (?:about )?(\d+)(?: to (\d+))? degrees")
_TURN_BETWEEN = re.compile(r"turned between (\d+) degrees (left|right) and (\d+) degrees (left|right)")


def _signed(degrees: str, side: str) -> float:
    return float(degrees) if side == "left" else -float(degrees)


def over_focal_statement(sentence: str) -> OverFocal | None:
    """The allowed motions of a sentence over focal hypotheses, or None for any other sentence."""
    match = _OVER_FOCAL.search(sentence)
    if match is None:
        return None
    turn, move = match.group("turn"), match.group("move")
    yaw: tuple[float, float] | None = None
    if span := _TURN_SPAN.search(turn):
        low, high = span.group(2), span.group(3) or span.group(2)
        ends = sorted((_signed(low, span.group(1)), _signed(high, span.group(1))))
        yaw = (ends[0], ends[1])
    elif between := _TURN_BETWEEN.search(turn):
        ends = sorted(
            (_signed(between.group(1), between.group(2)), _signed(between.group(3), between.group(4)))
        )
        yaw = (ends[0], ends[1])
    elif "did not turn" not in turn:
        return None
    directions: list[str | None] = []
    for part in move.removeprefix("moved ").split(" or "):
        directions.append(None if "stayed in place" in part else normalize_direction(part))
    heading = None
    if match.group("low") is not None:
        heading = (float(match.group("low")), float(match.group("high")))
    return OverFocal(directions=directions, yaw_range_deg=yaw, heading_range_deg=heading)


def motion_statements(clue_text: str) -> list[MotionStatement]:
    statements = []
    for line in clue_text.splitlines():
        for sentence in _SENTENCE_END.split(line.strip()):
            over = over_focal_statement(sentence)
            if over is not None:
                pair_match = _PAIR.search(sentence)
                pair = (int(pair_match.group(1)), int(pair_match.group(2))) if pair_match else None
                statements.append(
                    MotionStatement(
                        pair=pair,
                        sentence=sentence.strip(),
                        direction=None,
                        turn=None,
                        degrees=None,
                        over_focal=over,
                    )
                )
                continue
            main, gravity, target = _clauses(sentence)
            direction, turn = normalize_direction(main), normalize_turn(main)
            if direction is None and turn is None and not _MOVED_OR_NOT.search(main):
                continue
            reading = _no_turn_unless_named(_with_target(read_motion(main), target))
            if turn is None and reading.turn == "no turn":
                turn = "no turn"
            pair_match = _PAIR.search(sentence)
            pair = (int(pair_match.group(1)), int(pair_match.group(2))) if pair_match else None
            statements.append(
                MotionStatement(
                    pair=pair,
                    sentence=sentence.strip(),
                    direction=direction,
                    turn=turn,
                    degrees=turn_degrees(main),
                    reading=reading,
                    gravity=(
                        _no_turn_unless_named(_with_target(read_motion(gravity), target)) if gravity else None
                    ),
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


def hypothetical_statements(statement: MotionStatement) -> list[MotionStatement]:
    """Every motion a sentence over focal hypotheses allows, as plain statements: each heading of
    its range (whole degrees, with its direction word and `heading_deg`) with each whole-degree
    turn of its range. A superset of the hypotheses, so a choice that holds for all of these holds
    at every hypothesis."""
    over = statement.over_focal
    if over is None:
        return [statement]
    turns = (
        [("no turn", 0.0)] if over.yaw_range_deg is None else [_turn_of(y) for y in _span(over.yaw_range_deg)]
    )
    steps: list[tuple[str | None, float | None]] = []
    if over.heading_range_deg is not None:
        steps = [(direction_name(h), h) for h in _span(over.heading_range_deg)]
    else:
        steps = [(d, None) for d in over.directions if d is not None]
    if None in over.directions:
        steps.append((None, None))  # some hypothesis stayed in place
    return [
        statement.model_copy(
            update={"direction": d, "heading_deg": h, "turn": t, "degrees": g, "over_focal": None}
        )
        for d, h in dict.fromkeys(steps)
        for t, g in dict.fromkeys(turns)
    ]


def _span(ends: tuple[float, float]) -> list[float]:
    """Whole degrees from one end to the other, both ends included."""
    low, high = ends
    inner = np.arange(math.ceil(low), math.floor(high) + 1, dtype=float)
    return [float(x) for x in dict.fromkeys([low, *inner, high])]


def _turn_of(yaw_deg: float) -> tuple[str, float]:
    """The turn words and stated degrees camera_motion would give a yaw."""
    words = describe_turn(yaw_deg)
    return normalize_turn(words) or "no turn", turn_degrees(words) or 0.0


__all__ = [
    "VISION_MODEL_HINT",
    "MotionStatement",
    "OverFocal",
    "UNDETERMINED",
    "hypothetical_statements",
    "over_focal_statement",
    "unreadable_clue",
    "motion_statements",
    "not_a_motion_question",
    "pick_statement",
    "step_size",
]
