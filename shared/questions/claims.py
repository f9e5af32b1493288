"""Typed claims: what one option (or one clause of a stem) says about the camera.

An option is read (shared/questions/lexicon.py) into one claim: a `Translation` (the camera's step,
as up to two axis words: "left", "forward"), a `Rotation` (an axis, yaw / pitch / roll, and its
sense), a `Position` (where the second camera's centre lies in the first camera's frame: the same
geometry as the step, said as a place), `Still`, a `Compound` of parts ("moved left and turned
right"), a `Bare` direction ("Left": its kind is the one the question asks), or `Unread` (words the
lexicon does not cover; never guessed). Each claim keeps the words it came from (`source`).

`as_motion_reading` gives the claim in the motion vocabulary the measured sentence is read into
(shared/questions/motion_words.py), so a claim and a measurement compare quantity by quantity.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field

from shared.questions.motion_words import MotionReading

Way = Literal["left", "right", "up", "down", "forward", "backward"]
Axis = Literal["yaw", "pitch", "roll"]
# yaw: left / right / around; pitch: up / down; roll: clockwise / counterclockwise; any axis: none.
Sense = Literal["left", "right", "around", "up", "down", "clockwise", "counterclockwise", "none"]
ClaimKind = Literal["translation", "rotation", "position", "still"]

_OPPOSITE: dict[str, str] = {
    "left": "right",
    "right": "left",
    "up": "down",
    "down": "up",
    "forward": "backward",
    "backward": "forward",
}


class _Claim(BaseModel, frozen=True):
    source: str = Field("", description="The words the claim was read from.")


class Translation(_Claim, frozen=True):
    """The camera stepped this way (in the first view's axes); several ways: a diagonal."""

    kind: Literal["translation"] = "translation"
    ways: tuple[Way, ...]

    @property
    def words(self) -> str:
        return "camera moved " + " and ".join(self.ways)


class Position(_Claim, frozen=True):
    """The second camera's centre lies this way from the first camera, in the first camera's frame."""

    kind: Literal["position"] = "position"
    ways: tuple[Way, ...]

    @property
    def words(self) -> str:
        return "second camera " + " and ".join(_PLACE[way] for way in self.ways) + " the first"


_PLACE = {
    "left": "to the left of",
    "right": "to the right of",
    "up": "above",
    "down": "below",
    "forward": "in front of",
    "backward": "behind",
}


class Rotation(_Claim, frozen=True):
    kind: Literal["rotation"] = "rotation"
    axis: Axis
    sense: Sense
    degrees: float | None = None

    @property
    def words(self) -> str:
        verb = {"yaw": "turned", "pitch": "tilted", "roll": "rolled"}[self.axis]
        if self.sense == "none":
            return f"camera did not {verb.removesuffix('ed')}"
        about = f" by {self.degrees:g} degrees" if self.degrees is not None else ""
        return f"camera {verb} {self.sense}{about}"


class Target(_Claim, frozen=True):
    """The camera came closer to (or went farther from) a named object: a step, read against the
    measured distances to that object."""

    kind: Literal["target"] = "target"
    change: Literal["closer", "farther"]
    object: str = ""

    @property
    def words(self) -> str:
        return (
            f"camera came {self.change} {'to' if self.change == 'closer' else 'from'} {self.object}".strip()
        )


class Still(_Claim, frozen=True):
    kind: Literal["still"] = "still"

    @property
    def words(self) -> str:
        return "camera stayed still"


class Bare(_Claim, frozen=True):
    """Direction words with no verb ("Left", "Up"): what they mean is what the question asks."""

    kind: Literal["bare"] = "bare"
    ways: tuple[Way, ...]

    @property
    def words(self) -> str:
        return " and ".join(self.ways)


class Unread(_Claim, frozen=True):
    """Words outside the lexicon, or words that say two things at once; `why` says which."""

    kind: Literal["unread"] = "unread"
    why: str = "no word of it is in the motion lexicon"
    two_claims: bool = False  # it says two things at once ("left or back", "left and right")

    @property
    def words(self) -> str:
        return f"unread ({self.why})"


Part = Annotated[Translation | Position | Rotation | Still | Target, Field(discriminator="kind")]


class Compound(_Claim, frozen=True):
    """Several claims at once ("moved left and turned right"): each is matched on its own quantity."""

    kind: Literal["compound"] = "compound"
    parts: tuple[Part, ...]

    @property
    def words(self) -> str:
        return "; ".join(part.words for part in self.parts)


Claim = Annotated[
    Translation | Position | Rotation | Still | Target | Compound | Bare | Unread, Field(discriminator="kind")
]


def claim_kinds(claim: Claim) -> set[ClaimKind]:
    """The quantities a claim states (empty for a bare or unread one)."""
    parts = claim.parts if isinstance(claim, Compound) else (claim,)
    kinds: set[ClaimKind] = set()
    for part in parts:
        if isinstance(part, Target):
            kinds.add("translation")
        elif isinstance(part, Translation | Position | Rotation | Still):
            kinds.add(part.kind)  # type: ignore[arg-type]
    return kinds


def is_read(claim: Claim) -> bool:
    return not isinstance(claim, Unread | Bare)


def resolve_bare(claim: Claim, quantity: str) -> Claim:
    """A bare direction read as the quantity asked ("Up" in a tilt question is a tilt up); a claim
    that is not bare, or a quantity that gives bare words no one sense, is returned as it is."""
    if not isinstance(claim, Bare):
        return claim
    if quantity == "translation":
        return Translation(ways=claim.ways, source=claim.source)
    if quantity == "position":
        return Position(ways=claim.ways, source=claim.source)
    if quantity == "rotation" and len(claim.ways) == 1:
        way = claim.ways[0]
        if way in ("left", "right"):
            return Rotation(axis="yaw", sense=way, source=claim.source)
        if way in ("up", "down"):
            return Rotation(axis="pitch", sense=way, source=claim.source)
        if way == "backward":
            return Rotation(axis="yaw", sense="around", source=claim.source)
    return claim


_COMPASS = {
    ("forward",): "forward",
    ("backward",): "backward",
    ("left",): "left",
    ("right",): "right",
    ("forward", "left"): "diagonally forward and left",
    ("forward", "right"): "diagonally forward and right",
    ("backward", "left"): "diagonally back and left",
    ("backward", "right"): "diagonally back and right",
}


def _step_reading(ways: tuple[str, ...]) -> dict[str, object]:
    horizontal = tuple(
        sorted((w for w in ways if w in ("forward", "backward", "left", "right")), key=_AXIS_ORDER)
    )
    vertical = next((w for w in ways if w in ("up", "down")), None)
    return {"direction": _COMPASS.get(horizontal), "vertical": vertical}


def _AXIS_ORDER(way: str) -> int:  # noqa: N802 - a sort key
    return 0 if way in ("forward", "backward") else 1


def _rotation_reading(claim: Rotation) -> dict[str, object]:
    degrees = claim.degrees
    if claim.axis == "yaw":
        turn = "no turn" if claim.sense == "none" else f"turn {claim.sense}"
        if claim.sense == "around" and degrees is None:
            degrees = 180.0
        return {"turn": turn, "degrees": degrees}
    if claim.axis == "pitch":
        return {"tilt": "no tilt" if claim.sense == "none" else f"tilt {claim.sense}", "degrees": degrees}
    return {"roll": None if claim.sense == "none" else f"roll {claim.sense}", "degrees": degrees}


def as_motion_reading(claim: Claim) -> MotionReading | None:
    """The claim in the motion vocabulary (None for a bare or unread claim, or a roll of none)."""
    fields: dict[str, object] = {}
    parts = claim.parts if isinstance(claim, Compound) else (claim,)
    for part in parts:
        if isinstance(part, Translation | Position):
            fields.update({k: v for k, v in _step_reading(part.ways).items() if v is not None})
        elif isinstance(part, Rotation):
            fields.update({k: v for k, v in _rotation_reading(part).items() if v is not None})
        elif isinstance(part, Still):
            fields["still"] = True
        elif isinstance(part, Target):
            fields["target"] = part.change
        else:
            return None
    reading = MotionReading(**fields)  # type: ignore[arg-type]
    return reading if reading.stated() else None


def opposite(way: str) -> str:
    return _OPPOSITE[way]


__all__ = [
    "Axis",
    "Bare",
    "Claim",
    "ClaimKind",
    "Compound",
    "Position",
    "Rotation",
    "Sense",
    "Still",
    "Target",
    "Translation",
    "Unread",
    "Way",
    "as_motion_reading",
    "claim_kinds",
    "is_read",
    "opposite",
    "resolve_bare",
]
