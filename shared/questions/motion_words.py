"""One vocabulary for camera motion, read the same way from the program's sentences and from options.

`read_motion(text)` turns a phrase into a typed `MotionReading`: the compass step (one of
DIRECTIONS), the vertical step ("up" / "down"), the turn ("turn left", ...), the tilt ("tilt up",
"tilt down", "no tilt"), the roll ("roll clockwise", "roll counterclockwise"), "stayed still", and
closer to / farther from. People write the same motion many ways: "Down", "It moved down",
"downward", "Below the first camera", "lowered", "It stayed still", "panned left", "tilted upward",
"looked up", "rolled clockwise", "rotated counter-clockwise", "approached". The answerer compares
readings, never sentences.

A bare word means what the question asks about (`asked_motion`): "Which way did the camera tilt?
A. Up B. Down" reads "Up" as a tilt, "How did the camera turn? A. Left" reads "Left" as a turn.

The frame a question means (`asked_frame`): the photos' own axes ("image") unless it names the room
or gravity ("up in the room", "relative to the ground"), as MMSI-Bench's annotators wrote them.
"""

from __future__ import annotations

import re
from typing import Literal

from pydantic import BaseModel

from shared.questions.choices import normalize_direction, normalize_turn, turn_degrees

AskedMotion = Literal["any", "turn", "tilt", "roll", "move"]
Frame = Literal["image", "gravity"]
Vertical = Literal["up", "down"]
Tilt = Literal["tilt up", "tilt down", "no tilt"]
Roll = Literal["roll clockwise", "roll counterclockwise", "no roll"]  # "no roll": only an option's claim
TargetChange = Literal["closer", "farther"]


class MotionReading(BaseModel, frozen=True):
    """What a phrase says about a camera's motion; None where it says nothing."""

    direction: str | None = None  # compass step, one of shared.geometry.camera_motion.DIRECTIONS
    vertical: Vertical | None = None
    turn: str | None = None  # one of shared.questions.choices.TURNS
    tilt: Tilt | None = None
    roll: Roll | None = None
    still: bool = False
    target: TargetChange | None = None
    degrees: float | None = None  # of the turn, tilt or roll the phrase states

    def stated(self) -> dict[str, object]:
        """The components the phrase states (still included when it says so)."""
        return {key: value for key, value in self.model_dump(exclude={"degrees"}).items() if value}


def _words(text: str) -> str:
    lowered = re.sub(r"[-_/]", " ", (text or "").lower())
    lowered = re.sub(r"[^a-z0-9°.\s]", " ", lowered)
    return " ".join(lowered.split())


_FILLER = (
    r"(?:(?:by|to|the|its|about|around|roughly|approximately|slightly|a bit|camera|lens|view"
    r"|\d+(?:\.\d+)?°?|°|degrees?|deg)\s+)*"
)
_TILT = re.compile(
    r"\b(?:tilt|tilted|tilting|tilts|pitch|pitched|pitching|look|looked|looking|aimed|angled|pointed)\s+"
    + _FILLER
    + r"(up|upward|upwards|down|downward|downwards)\b"
)
_NO_TILT = re.compile(r"\b(?:no (?:significant )?(?:tilt|pitch)|without tilting|did not tilt|didn t tilt)\b")
_ROLL = re.compile(
    r"\b(?:(?:roll|rolled|rolling|rolls|rotate|rotated|rotating|rotates|rotation|turned|twisted|spun|tilted)\s+"
    + _FILLER
    + r")?(clockwise|counterclockwise|counter clockwise|anticlockwise|anti clockwise)\b"
)
_UP = re.compile(
    r"\b(?:up|upward|upwards|upper|above|higher|rose|risen|raised|lifted|ascended|elevated|climbed)\b"
)
_DOWN = re.compile(r"\b(?:down|downward|downwards|below|beneath|lower|lowered|descended|dropped|sank)\b")
_STILL = re.compile(
    r"\b(?:stayed still|stood still|kept still|still|stationary|motionless|did not move|didn t move|not move"
    r"|no (?:significant )?(?:movement|motion|change)|neither moved|remained (?:in place|in the same place)"
    r"|(?:the )?same (?:position|place|pose|spot|location)|unchanged|static)\b"
)
_CLOSER = re.compile(r"\b(?:closer|nearer|approach\w*|toward|towards)\b")
_FARTHER = re.compile(r"\b(?:farther|further|away from|receded|retreated)\b")
_STRAIGHT = re.compile(r"\bstraight (up|down|upward|downward)\b")


def _roll_of(words: str) -> Roll | None:
    sides = {
        "counterclockwise" if "counter" in m or "anti" in m else "clockwise" for m in _ROLL.findall(words)
    }
    return f"roll {sides.pop()}" if len(sides) == 1 else None  # type: ignore[return-value]


def _tilt_of(words: str) -> Tilt | None:
    sides = {"tilt up" if side.startswith("up") else "tilt down" for side in _TILT.findall(words)}
    if len(sides) == 1:
        return sides.pop()  # type: ignore[return-value]
    return "no tilt" if not sides and _NO_TILT.search(words) else None


def _vertical_of(words: str) -> Vertical | None:
    up, down = bool(_UP.search(words)), bool(_DOWN.search(words))
    if up == down:
        return None
    return "up" if up else "down"


def read_motion(text: str, asked: AskedMotion = "any") -> MotionReading:
    """The motion a phrase states (see the module docstring); `asked` gives bare words their sense."""
    words = _words(text)
    roll, tilt = _roll_of(words), _tilt_of(words)
    rest = _NO_TILT.sub(" ", _ROLL.sub(" ", _TILT.sub(" ", _STRAIGHT.sub(r"\1", words))))
    turn = normalize_turn(rest)
    rotated = turn not in (None, "no turn") or tilt not in (None, "no tilt") or roll is not None
    # "stayed in the same spot and turned left" is a turn, not still
    still = (
        bool(_STILL.search(rest)) and not rotated and not re.search(r"\bstill (?:moved|turned|went)\b", rest)
    )
    direction = None if still else normalize_direction(rest)
    vertical = None if still else _vertical_of(_without_turn_words(rest))
    target = "closer" if _CLOSER.search(rest) else "farther" if _FARTHER.search(rest) else None
    if asked == "tilt" and tilt is None and vertical is not None and direction is None:
        tilt, vertical = ("tilt up" if vertical == "up" else "tilt down"), None
    if asked == "turn" and turn is None and direction in ("left", "right") and vertical is None:
        turn, direction = f"turn {direction}", None
    elif asked == "turn" and turn is None and direction == "backward":
        turn, direction = "turn around", None
    degrees = turn_degrees(rest) if turn is not None else _degrees(words)
    return MotionReading(
        direction=direction,
        vertical=vertical,
        turn=turn,
        tilt=tilt,
        roll=roll,
        still=still,
        target=target,  # type: ignore[arg-type]
        degrees=degrees,
    )


_TURN_PHRASE = re.compile(
    r"\b(?:turn|turned|turning|rotate|rotated|rotating|pan|panned|panning)\s+(?:around|round)\b"
)


def _without_turn_words(words: str) -> str:
    return _TURN_PHRASE.sub(" ", words)


_DEGREES = re.compile(r"(\d+(?:\.\d+)?)\s*(?:°|degrees?\b|deg\b)")


def _degrees(words: str) -> float | None:
    found = _DEGREES.search(words)
    return float(found.group(1)) if found else None


_ASKS_TILT = re.compile(r"\b(?:tilt\w*|pitch\w*|look(?:ed|ing)? (?:up|down)|angle up|angle down)\b", re.I)
_ASKS_ROLL = re.compile(r"\b(?:roll\w*|clockwise|counterclockwise|counter clockwise|anticlockwise)\b", re.I)
_ASKS_TURN = re.compile(r"\b(?:turn\w*|rotat\w*|pan\w*|yaw\w*|face|facing)\b", re.I)
_ASKS_MOVE = re.compile(
    r"\b(?:move\w*|movement|walk\w*|travel\w*|went|step\w*|go|shift\w*|translat\w*)\b", re.I
)


def asked_motion(ask: str) -> AskedMotion:
    """Which motion a question asks about, for bare option words ("Up", "Left")."""
    move = bool(_ASKS_MOVE.search(ask))
    if _ASKS_TILT.search(ask) and not move:
        return "tilt"
    if _ASKS_ROLL.search(ask) and not move:
        return "roll"
    if _ASKS_TURN.search(ask) and not move:
        return "turn"
    return "move" if move else "any"


_GRAVITY_WORDS = re.compile(
    r"\b(?:in the (?:room|world|real world)"
    r"|relative to (?:the )?(?:ground|floor|gravity|room|world|scene)"
    r"|gravity|vertically in the room|above the floor|toward the ceiling|toward the floor)\b",
    re.IGNORECASE,
)


def asked_frame(question: str) -> Frame:
    """'gravity' when the question names the room's or the ground's up, else 'image' (the photos' axes)."""
    return "gravity" if _GRAVITY_WORDS.search(question or "") else "image"


def agrees(option: MotionReading, statement: MotionReading) -> tuple[bool, int]:
    """Whether everything an option states holds in the statement, and how many components it states."""
    stated = option.stated()
    if not stated:
        return False, 0
    if option.still and not statement.still:
        return False, len(stated)
    said = _settled(statement)
    for key in ("direction", "vertical", "turn", "tilt", "roll", "target"):
        wanted = getattr(option, key)
        if wanted is not None and wanted != getattr(said, key):
            return False, len(stated)
    return True, len(stated)


def _settled(statement: MotionReading) -> MotionReading:
    """A statement with what its silence means: no tilt said is no tilt; still is no turn and no tilt."""
    update: dict[str, object] = {"tilt": statement.tilt or "no tilt", "roll": statement.roll or "no roll"}
    if statement.still:
        update.update(direction=None, vertical=None, turn="no turn", tilt="no tilt", roll="no roll")
    return statement.model_copy(update=update)


__all__ = [
    "AskedMotion",
    "Frame",
    "MotionReading",
    "agrees",
    "asked_frame",
    "asked_motion",
    "read_motion",
]
