"""Which parts of a pair's camera motion the photos determine when the focal length is unknown.

Two photos of unknown focal fit a range of focal lengths almost equally well, and the relative pose
changes with the focal. A backbone then solves the pair at each plausible horizontal field of view
(a hypothesis) and keeps those the matches support. Here each hypothesis's relative pose is read
with the rules of camera_motion.py (same compass, same turn threshold), and a quantity is
*determined* when every supported hypothesis gives it the same words: "turned left by 12 to 42
degrees (determined) and moved forward or diagonally forward and left (not determined)".

A hypothesis is the relative pose x_second = R x_first + t (camera axes of the first view, OpenCV),
t a unit vector or zero (pure rotation), as two-view geometry gives it. The up axis of each
hypothesis is estimated from its own two cameras (poses.estimate_up_axis), since it moves with the
focal too.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import numpy as np

from shared.geometry.camera_motion import (
    NO_MOVEMENT,
    NO_ROTATION,
    CameraMotion,
    UnknownMotion,
    describe_camera_motion,
)

DETERMINED = "(determined)"
NOT_DETERMINED = "(not determined)"
NO_TURN_WORDS = "did not turn significantly"


@dataclass
class PairHypotheses:
    """The supported focal hypotheses of one pair of views (0-based), in increasing field of view."""

    first: int
    second: int
    fov_deg: list[float]  # horizontal field of view of each hypothesis
    rotations: list[list[list[float]]]  # per hypothesis 3x3, x_second = R x_first + t
    translations: list[list[float]]  # per hypothesis a unit 3-vector, or zeros (pure rotation)
    inliers: list[int]  # matches each hypothesis explains

    def reversed(self) -> PairHypotheses:
        """The same hypotheses for the pair (second, first)."""
        rotations, translations = [], []
        for rotation, translation in zip(self.rotations, self.translations, strict=True):
            inverse = np.asarray(rotation).T
            rotations.append(inverse.tolist())
            translations.append((-inverse @ np.asarray(translation)).tolist())
        return PairHypotheses(
            self.second, self.first, list(self.fov_deg), rotations, translations, list(self.inliers)
        )


@dataclass
class FocalHypotheses:
    """What a reconstruction of unknown, unobservable focal stores: the grid and each pair's support."""

    tested_fov_deg: list[float]  # the grid that was tried
    central_fov_deg: float  # the hypothesis the stored poses (and renders) use
    pairs: list[PairHypotheses] = field(default_factory=list)

    def for_pair(self, first: int, second: int) -> PairHypotheses | None:
        for pair in self.pairs:
            if (pair.first, pair.second) == (first, second):
                return pair
            if (pair.second, pair.first) == (first, second):
                return pair.reversed()
        return None

    def to_dict(self) -> dict[str, object]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> FocalHypotheses:
        pairs = [PairHypotheses(**pair) for pair in data.get("pairs", [])]
        return cls(list(data["tested_fov_deg"]), float(data["central_fov_deg"]), pairs)


@dataclass(frozen=True)
class MotionOverFocal:
    """A pair's motion over every supported hypothesis, and which words all of them share."""

    from_view: int
    to_view: int
    hypotheses: int
    fov_range_deg: tuple[float, float]
    yaw_range_deg: tuple[float, float]  # signed, positive = left (camera_motion's convention)
    turns: list[str]  # the distinct turn sides in hypothesis order: "left", "right", "none"
    turn_determined: bool
    directions: list[str]  # the distinct horizontal directions (camera_motion.DIRECTIONS or NO_MOVEMENT)
    direction_determined: bool
    vertical_directions: list[str]  # distinct "up", "down", "none"
    vertical_determined: bool
    translation_directions: list[list[float]]  # per hypothesis, unit step in the first camera's axes
    sentence: str

    def to_dict(self) -> dict[str, object]:
        result = asdict(self)
        result["fov_range_deg"] = list(self.fov_range_deg)
        result["yaw_range_deg"] = list(self.yaw_range_deg)
        return result


def _distinct(values: list[str]) -> list[str]:
    return list(dict.fromkeys(values))


def _turn_side(yaw_deg: float, turn: str) -> str:
    if turn == NO_ROTATION:
        return "none"
    return "left" if yaw_deg > 0 else "right"


def turn_words(turns: list[str], yaw_range_deg: tuple[float, float]) -> str:
    """The turn clause: a side with its range when one side holds, else the signed range."""
    low, high = yaw_range_deg
    if turns == ["none"]:
        return NO_TURN_WORDS
    if len(turns) == 1:
        magnitudes = sorted((abs(low), abs(high)))
        if round(magnitudes[1]) - round(magnitudes[0]) < 1:
            return f"turned {turns[0]} by about {round(magnitudes[1])} degrees"
        return f"turned {turns[0]} by {round(magnitudes[0])} to {round(magnitudes[1])} degrees"

    def side(yaw: float) -> str:
        return f"{round(abs(yaw))} degrees {'left' if yaw > 0 else 'right'}"

    return f"turned between {side(low)} and {side(high)}"


def motion_over_focal(
    hypotheses: PairHypotheses, threshold: float = 0.05, rotation_threshold_deg: float = 10.0
) -> MotionOverFocal:
    """The pair's motion at every hypothesis and what they all agree on (see the module docstring).

    The step is a unit vector (or zero), so `threshold` is a share of the baseline: a step is
    "no significant movement" only for a pure-rotation hypothesis."""
    if not hypotheses.fov_deg:
        raise ValueError(f"pair ({hypotheses.first}, {hypotheses.second}) has no supported hypothesis")
    yaws, turns, directions, verticals, steps = [], [], [], [], []
    for rotation, translation in zip(hypotheses.rotations, hypotheses.translations, strict=True):
        second = np.concatenate([np.asarray(rotation, float), np.asarray(translation, float)[:, None]], 1)
        first = np.concatenate([np.eye(3), np.zeros((3, 1))], 1)
        (motion,) = describe_camera_motion(
            np.stack([first, second]),
            scene_scale=1.0,
            threshold=threshold,
            rotation_threshold_deg=rotation_threshold_deg,
        )
        yaws.append(motion.yaw_deg)
        turns.append(_turn_side(motion.yaw_deg, motion.turn))
        directions.append(motion.direction)
        verticals.append(motion.vertical_direction or "none")
        step = np.asarray(motion.displacement_in_first_camera)
        norm = np.linalg.norm(step)
        steps.append((step / norm if norm > 1e-12 else step).tolist())
    yaw_range = (float(min(yaws)), float(max(yaws)))
    fov_range = (float(min(hypotheses.fov_deg)), float(max(hypotheses.fov_deg)))
    turns, directions, verticals = _distinct(turns), _distinct(directions), _distinct(verticals)
    return MotionOverFocal(
        from_view=hypotheses.first,
        to_view=hypotheses.second,
        hypotheses=len(hypotheses.fov_deg),
        fov_range_deg=fov_range,
        yaw_range_deg=yaw_range,
        turns=turns,
        turn_determined=len(turns) == 1,
        directions=directions,
        direction_determined=len(directions) == 1,
        vertical_directions=verticals,
        vertical_determined=len(verticals) == 1,
        translation_directions=steps,
        sentence=determinacy_sentence(
            hypotheses.first, hypotheses.second, turns, yaw_range, directions, fov_range
        ),
    )


def _mark(determined: bool) -> str:
    return DETERMINED if determined else NOT_DETERMINED


def determinacy_sentence(
    first: int,
    second: int,
    turns: list[str],
    yaw_range_deg: tuple[float, float],
    directions: list[str],
    fov_range_deg: tuple[float, float],
) -> str:
    """One sentence (1-based view numbers) that the agent's offline answerer reads back."""
    moves = [d for d in directions if d != NO_MOVEMENT]
    if not moves:
        moved = "stayed in place"
    else:
        moved = (
            "moved " + " or ".join(moves) + (" or stayed in place" if len(moves) < len(directions) else "")
        )
    low, high = fov_range_deg
    fovs = f"{round(low)} to {round(high)} degrees" if round(high) != round(low) else f"{round(low)} degrees"
    return (
        f"From view {first + 1} to view {second + 1} the camera {turn_words(turns, yaw_range_deg)} "
        f"{_mark(len(turns) == 1)} and {moved} {_mark(len(directions) == 1)}, over every horizontal "
        f"field of view the photos allow ({fovs}; the focal length is unknown)."
    )


def with_motion_over_focal(
    motion: CameraMotion | UnknownMotion, hypotheses: FocalHypotheses | None
) -> CameraMotion | UnknownMotion:
    """A described pair with its motion over the focal hypotheses (and their sentence), if any."""
    if hypotheses is None or not isinstance(motion, CameraMotion):
        return motion
    pair = hypotheses.for_pair(motion.from_view, motion.to_view)
    if pair is None or not pair.fov_deg:
        return motion
    over = motion_over_focal(pair)
    fields = {k: v for k, v in over.to_dict().items() if k not in ("from_view", "to_view")}
    return replace(motion, over_focal=fields, sentence=over.sentence)


__all__ = [
    "DETERMINED",
    "NOT_DETERMINED",
    "FocalHypotheses",
    "MotionOverFocal",
    "PairHypotheses",
    "determinacy_sentence",
    "motion_over_focal",
    "turn_words",
    "with_motion_over_focal",
]
