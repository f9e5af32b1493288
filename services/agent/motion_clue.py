"""Camera-motion sentences in a program's text output, and the one about the pair a question asks.

"From view 1 to view 2 the camera moved diagonally forward and right and turned left by about 45
degrees." becomes a `MotionStatement` (pair, direction, turn, degrees), wording normalized by
shared.questions.choices. Both offline answerers read them: the multiple-choice one compares them
with the options (answering.py), the free-form one says them in words (free_form.py).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np
from pydantic import BaseModel

from shared.geometry.camera_motion import (
    describe_roll,
    describe_tilt,
    describe_turn,
    direction_name,
    round_turn,
)
from shared.questions.choices import normalize_direction, normalize_turn, turn_degrees
from shared.questions.intent import QuestionIntent
from shared.questions.motion_words import AskedMotion, Frame, MotionReading, read_motion
from shared.questions.reading import QuestionReading

VISION_MODEL_HINT = (
    "set PYSPATIAL_ANSWER_MODEL (and PYSPATIAL_ANSWER_MODEL_BASE_URL, PYSPATIAL_ANSWER_MODEL_API_KEY) "
    "to a vision-capable chat model"
)
# What the offline answerers say when the motion differs between the focal lengths the photos allow.
UNDETERMINED = "cannot be determined from these photos"
# Over focal hypotheses the motion is read in view 1's image axes only (motion_determinacy.py).
NO_GRAVITY_OVER_FOCAL = (
    "the question asks about the room's up (its gravity frame), but with the focal length unknown "
    "the motion is known only in the first photo's own axes"
)
_PAIR = re.compile(r"\b(?:view|image)\s+(\d+)\b.*?\b(?:view|image)\s+(\d+)\b", re.IGNORECASE)
_SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z])")
_MOVED_OR_NOT = re.compile(
    r"\b(?:moved|stayed in place|stayed still|neither moved|tilted|rolled)\b", re.IGNORECASE
)
_GRAVITY_CLAUSE = re.compile(r"^in the scene'?s gravity frame (?:it )?", re.IGNORECASE)
_END_AXES_CLAUSE = re.compile(r"^in view (?P<view>\d+)'?s image axes it ", re.IGNORECASE)
_TARGET_CLAUSE = re.compile(r"^it (?:came closer to|moved farther from|stayed as far from)\b", re.IGNORECASE)
_STEP = re.compile(r"\b(?:a step of )?(\d+(?:\.\d+)?) ?(m|scene units)\b")


class OverFocal(BaseModel):
    """What a sentence over an unknown focal allows (motion_determinacy.determinacy_sentence), per
    quantity. A signed angle range is None when no hypothesis turned (tilted, rolled) significantly;
    a quantity the sentence does not state at all (`unstated`) may be anything."""

    directions: list[str | None]  # every horizontal step some hypothesis gives; None = no such step
    yaw_range_deg: tuple[float, float] | None  # signed, + = left; None: no significant turn throughout
    heading_range_deg: tuple[float, float] | None = None  # of the step: 0 forward, + right
    verticals: list[str | None] = [None]  # "up", "down"; None = no vertical step
    tilt_range_deg: tuple[float, float] | None = None  # + = up
    roll_range_deg: tuple[float, float] | None = None  # + = clockwise
    stayed_in_place: bool = False  # every hypothesis is a pure rotation
    unstated: list[str] = []  # of "vertical", "tilt", "roll": older sentences say only turn and step
    clauses: dict[str, str] = {}  # each quantity's words with its mark, for refusals


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

    # The step again in the second view's own image axes (camera_motion.py states it when the views
    # rotated): its view and reading (direction and vertical only).
    end_axes: tuple[int, MotionReading] | None = None

    over_focal: OverFocal | None = None  # set for a motion over focal hypotheses (then the above are None)

    def reading_for(self, frame: Frame) -> MotionReading:
        """The reading in the frame the question means (its intent's `motion_frame`)."""
        if frame == "gravity" and self.gravity is not None:
            return self.gravity
        return self.reading or read_motion(self.sentence)


def _end_axes(clause: str | None) -> tuple[int, MotionReading] | None:
    """The second view's number and the step its axes give, from 'in view 2's image axes it moved left'."""
    found = _END_AXES_CLAUSE.match(clause or "")
    if found is None:
        return None
    step = read_motion(clause[found.end() :])  # type: ignore[index]
    return int(found.group("view")), MotionReading(direction=step.direction, vertical=step.vertical)


def _clauses(sentence: str) -> tuple[str, str | None, str | None, str | None]:
    """(the first frame's clause, the gravity frame's, the target's, the second view's axes') of one
    motion sentence."""
    main, gravity, target, end = "", None, None, None
    for position, clause in enumerate(part.strip() for part in sentence.rstrip(".").split(";")):
        if position and _GRAVITY_CLAUSE.match(clause):
            gravity = _GRAVITY_CLAUSE.sub("", clause)
        elif position and _END_AXES_CLAUSE.match(clause):
            end = clause
        elif position and _TARGET_CLAUSE.match(clause):
            target = clause
        else:
            main = f"{main}; {clause}" if main else clause
    return main, gravity, target, end


def _with_target(reading: MotionReading, target: str | None) -> MotionReading:
    if target is None:
        return reading
    return reading.model_copy(update={"target": read_motion(target).target})


# "From view 1 to view 2 the camera turned left by 12 to 42 degrees (determined) and moved forward or
# ... (not determined; heading -45 to 0 degrees, ...); it moved down (determined); it tilted up by 6 to
# 9 degrees (determined); it did not roll significantly (determined); in view 1's image axes, ..."
_OVER_FOCAL = re.compile(
    r"the camera (?P<turn>.+?) (?P<turn_mark>\((?:not )?determined\)) and (?P<move>.+?) "
    r"(?P<move_mark>\((?:not )?determined(?:; heading (?P<low>-?\d+) to (?P<high>-?\d+) degrees[^)]*)?\))"
)
_CLAUSE = re.compile(r"^it (?P<words>.+?) \((?:not )?determined\)$")
_SIDES = {"left": 1.0, "right": -1.0, "up": 1.0, "down": -1.0, "clockwise": 1.0, "counterclockwise": -1.0}
_SIDE = "left|right|up|down|counterclockwise|clockwise"
_ANGLE_SPAN = re.compile(rf"(?:turned|tilted|rolled) ({_SIDE}) by (?:about )?(\d+)(?: to (\d+))? degrees")
_ANGLE_BETWEEN = re.compile(
    rf"(?:turned|tilted|rolled) between (\d+) degrees ({_SIDE}) and (\d+) degrees ({_SIDE})"
)
_NO_ANGLE = re.compile(r"\bdid not (?:turn|tilt|roll)\b")
_QUANTITY_OF_VERB = {"turned": "turn", "tilted": "tilt", "rolled": "roll", "tilt": "tilt", "roll": "roll"}


def _signed(degrees: str, side: str) -> float:
    return _SIDES[side] * float(degrees)


def angle_range(words: str) -> tuple[float, float] | None | bool:
    """The signed range (+ = left, up, clockwise) an angle clause states, None when it says there was
    no significant one, False when it is no angle clause."""
    if span := _ANGLE_SPAN.search(words):
        low, high = span.group(2), span.group(3) or span.group(2)
        first, second = sorted((_signed(low, span.group(1)), _signed(high, span.group(1))))
        return first, second
    if between := _ANGLE_BETWEEN.search(words):
        first, second = sorted(
            (_signed(between.group(1), between.group(2)), _signed(between.group(3), between.group(4)))
        )
        return first, second
    return None if _NO_ANGLE.search(words) else False


def _clause_quantity(words: str) -> str | None:
    """Which quantity an 'it ...' clause states: vertical, tilt or roll."""
    if words.startswith(("moved up", "moved down", "made no vertical step")):
        return "vertical"
    verb = re.match(r"(?:did not )?(\w+)", words)
    return _QUANTITY_OF_VERB.get(verb.group(1)) if verb else None


def over_focal_statement(sentence: str) -> OverFocal | None:
    """The allowed motions of a sentence over focal hypotheses, or None for any other sentence."""
    match = _OVER_FOCAL.search(sentence)
    if match is None:
        return None
    yaw = angle_range(match.group("turn"))
    if yaw is False:
        return None
    move = match.group("move")
    directions: list[str | None] = []
    for part in move.removeprefix("moved ").split(" or "):
        moved = "stayed in place" not in part and "no horizontal step" not in part
        directions.append(normalize_direction(part) if moved else None)
    heading = None
    if match.group("low") is not None:
        # The sentence's heading is left-positive; camera_motion's sectors count right-positive.
        heading = (-float(match.group("high")), -float(match.group("low")))
    found: dict[str, object] = {}
    clauses = {
        "turn": f"{match.group('turn')} {match.group('turn_mark')}",
        "step": f"{move} {match.group('move_mark')}",
    }
    for part in sentence.rstrip(".").split("; ")[1:]:
        clause = _CLAUSE.match(part.strip())
        quantity = _clause_quantity(clause.group("words")) if clause else None
        if clause is None or quantity is None:
            continue
        clauses[quantity] = part.strip()
        words = clause.group("words")
        if quantity == "vertical":
            found["verticals"] = [
                None if "no vertical step" in w else w.removeprefix("moved ") for w in words.split(" or ")
            ]
        elif (span := angle_range(words)) is not False:
            found[f"{quantity}_range_deg"] = span
    return OverFocal(
        directions=directions,
        yaw_range_deg=yaw,  # type: ignore[arg-type]
        heading_range_deg=heading,
        stayed_in_place="stayed in place" in move,
        unstated=[q for q in ("vertical", "tilt", "roll") if q not in clauses],  # older sentences
        clauses=clauses,
        **found,  # type: ignore[arg-type]
    )


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
            main, gravity, target, end = _clauses(sentence)
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
                    end_axes=_end_axes(end),
                )
            )
    return statements


def step_size(clause: str) -> str | None:
    """The step's size a clause states ('0.09 scene units', '0.42 m'), or None."""
    found = _STEP.search(clause)
    return f"{found.group(1)} {found.group(2)}" if found else None


def not_a_motion_question(intent: QuestionIntent, reading: QuestionReading | None = None) -> str | None:
    """Why a motion sentence cannot answer this question (None when it can): a camera reading (or a
    self-movement question) can, whatever else the old families would have named."""
    if intent.family == "self_movement" or (reading is not None and reading.is_camera):
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


class Hypothetical(NamedTuple):
    """One motion a sentence over focal hypotheses allows: its reading, and its step's heading."""

    reading: MotionReading
    heading_deg: float | None  # 0 forward, + right; None when the sentence gives no heading range


_QUANTITY_KEYS = ("direction", "vertical", "turn", "tilt", "roll", "still")


def hypothetical_readings(
    over: OverFocal, asked: AskedMotion = "any", keys: Iterable[str] = _QUANTITY_KEYS, degrees: bool = True
) -> list[Hypothetical]:
    """Every motion a sentence over focal hypotheses allows: each whole degree of each angle range
    (with the words and degrees camera_motion would say) with each step it names. A superset of the
    hypotheses, so a choice that holds for all of these holds at every hypothesis. `keys`: the
    reading's fields that matter (the others take one allowed value each); `degrees`: whether the
    asked angle's degrees matter (else one per word)."""
    wanted = {"step" if key == "direction" else key for key in keys}
    choices = _allowed(over)
    angle = asked if asked in ("tilt", "roll") else "turn"
    for name, values in choices.items():
        if name not in wanted:
            choices[name] = values[:1]
        elif name != angle or not degrees:  # one per word; a step keeps its headings
            choices[name] = values if name == "step" else list({v[0]: v for v in values}.values())
    found = []
    for step, vertical, turn, tilt, roll in itertools.product(
        *(choices[name] for name in ("step", "vertical", "turn", "tilt", "roll"))
    ):
        rotated = turn[0] != "no turn" or tilt[0] != "no tilt" or roll[0] is not None
        stated = {"turn": turn[1], "tilt": tilt[1], "roll": roll[1]}
        reading = MotionReading(
            direction=step[0],
            vertical=vertical[0],
            turn=turn[0],
            tilt=tilt[0],
            roll=roll[0],
            still=over.stayed_in_place and not rotated,
            degrees=stated[angle]
            if stated[angle] is not None
            else next((value for value in stated.values() if value), None),
        )
        found.append(Hypothetical(reading, step[1]))
    return list(dict.fromkeys(found))


def _allowed(over: OverFocal) -> dict[str, list[tuple]]:
    """Per quantity, every (word, number) the sentence allows; an unstated one allows anything."""
    turns = (
        [("no turn", None)]
        if over.yaw_range_deg is None
        else [_turn_of(y) for y in _span(over.yaw_range_deg)]
    )
    if over.heading_range_deg is not None:
        steps: list[tuple] = [(direction_name(h), h) for h in _span(over.heading_range_deg)]
    else:
        steps = [(d, None) for d in over.directions if d is not None]
    if None in over.directions:
        steps.append((None, None))  # some hypothesis made no horizontal step
    verticals = (
        [("up",), ("down",), (None,)] if "vertical" in over.unstated else [(v,) for v in over.verticals]
    )
    return {
        "step": list(dict.fromkeys(steps)),
        "vertical": list(dict.fromkeys(verticals)),
        "turn": list(dict.fromkeys(turns)),
        "tilt": _angle_words(over.tilt_range_deg, "tilt" in over.unstated, "tilt"),
        "roll": _angle_words(over.roll_range_deg, "roll" in over.unstated, "roll"),
    }


_ANY_TILT = [("tilt up", None), ("tilt down", None), ("no tilt", None)]
_ANY_ROLL = [("roll clockwise", None), ("roll counterclockwise", None), (None, None)]


def _angle_words(span: tuple[float, float] | None, unstated: bool, kind: str) -> list[tuple]:
    """(reading word, stated degrees) of each whole degree of a tilt ("tilt") or roll range."""
    if unstated:
        return _ANY_TILT if kind == "tilt" else _ANY_ROLL
    none = "no tilt" if kind == "tilt" else None
    if span is None:
        return [(none, None)]
    found = []
    for value in _span(span):
        words = describe_tilt(value) if kind == "tilt" else describe_roll(value)
        if words is None:
            found.append((none, None))
            continue
        reading = read_motion(words)
        found.append((reading.tilt if kind == "tilt" else reading.roll, float(round_turn(value))))
    return list(dict.fromkeys(found))


def _span(ends: tuple[float, float]) -> list[float]:
    """Whole degrees from one end to the other, both ends included."""
    low, high = ends
    inner = np.arange(math.ceil(low), math.floor(high) + 1, dtype=float)
    return [float(x) for x in dict.fromkeys([low, *inner, high])]


def _turn_of(yaw_deg: float) -> tuple[str, float | None]:
    """The turn words and stated degrees camera_motion would give a yaw."""
    words = describe_turn(yaw_deg)
    turn = normalize_turn(words) or "no turn"
    return turn, None if turn == "no turn" else turn_degrees(words)


__all__ = [
    "VISION_MODEL_HINT",
    "MotionStatement",
    "OverFocal",
    "NO_GRAVITY_OVER_FOCAL",
    "UNDETERMINED",
    "Hypothetical",
    "angle_range",
    "hypothetical_readings",
    "over_focal_statement",
    "unreadable_clue",
    "motion_statements",
    "not_a_motion_question",
    "step_size",
]
