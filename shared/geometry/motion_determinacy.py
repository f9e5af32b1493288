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
    unknown_motion,
)

# The start of the uncertain_reason of a view whose pose is one focal hypothesis of many: camera
# motion then reads the pair's hypotheses rather than refusing the view.
FOCAL_HYPOTHESIS_REASON = "its pose rests on one focal hypothesis"
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
    heading_range_deg: tuple[float, float] | None = None  # of the steps, 0 forward, + right (angle_deg)

    def to_dict(self) -> dict[str, object]:
        result = asdict(self)
        result["fov_range_deg"] = list(self.fov_range_deg)
        result["yaw_range_deg"] = list(self.yaw_range_deg)
        result["heading_range_deg"] = None if self.heading_range_deg is None else list(self.heading_range_deg)
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


def circular_range(angles_deg: list[float]) -> tuple[float, float]:
    """The smallest signed interval holding every angle (degrees), measured from the first one:
    (170, -175) gives (170, 185), not (-175, 170)."""
    reference = angles_deg[0]
    offsets = [(angle - reference + 180.0) % 360.0 - 180.0 for angle in angles_deg]
    return float(reference + min(offsets)), float(reference + max(offsets))


def hypothesis_motions(
    hypotheses: PairHypotheses, threshold: float = 0.05, rotation_threshold_deg: float = 10.0
) -> list[CameraMotion]:
    """camera_motion's description of each hypothesis's relative pose (up from its two cameras)."""
    first = np.concatenate([np.eye(3), np.zeros((3, 1))], 1)
    motions = []
    for rotation, translation in zip(hypotheses.rotations, hypotheses.translations, strict=True):
        second = np.concatenate([np.asarray(rotation, float), np.asarray(translation, float)[:, None]], 1)
        (motion,) = describe_camera_motion(
            np.stack([first, second]),
            scene_scale=1.0,
            threshold=threshold,
            rotation_threshold_deg=rotation_threshold_deg,
        )
        motions.append(motion)
    return motions


def motion_over_focal(
    hypotheses: PairHypotheses, threshold: float = 0.05, rotation_threshold_deg: float = 10.0
) -> MotionOverFocal:
    """The pair's motion at every hypothesis and what they all agree on (see the module docstring).

    The step is a unit vector (or zero), so `threshold` is a share of the baseline: a step is
    "no significant movement" only for a pure-rotation hypothesis."""
    if not hypotheses.fov_deg:
        raise ValueError(f"pair ({hypotheses.first}, {hypotheses.second}) has no supported hypothesis")
    motions = hypothesis_motions(hypotheses, threshold, rotation_threshold_deg)
    steps = []
    for motion in motions:
        step = np.asarray(motion.displacement_in_first_camera)
        norm = np.linalg.norm(step)
        steps.append((step / norm if norm > 1e-12 else step).tolist())
    yaw_range = circular_range([m.yaw_deg for m in motions])
    headings = [m.angle_deg for m in motions if m.direction != NO_MOVEMENT]
    heading_range = circular_range(headings) if headings else None
    fov_range = (float(min(hypotheses.fov_deg)), float(max(hypotheses.fov_deg)))
    turns = _distinct([_turn_side(m.yaw_deg, m.turn) for m in motions])
    directions = _distinct([m.direction for m in motions])
    verticals = _distinct([m.vertical_direction or "none" for m in motions])
    words = Words(turns, yaw_range, directions, heading_range)
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
        sentence=determinacy_sentence(hypotheses.first, hypotheses.second, words, fov_range),
        heading_range_deg=heading_range,
    )


@dataclass(frozen=True)
class Words:
    """What a determinacy sentence says of a pair over its hypotheses."""

    turns: list[str]
    yaw_range_deg: tuple[float, float]
    directions: list[str]
    heading_range_deg: tuple[float, float] | None  # of the steps that moved; None when none did


def _mark(determined: bool) -> str:
    return DETERMINED if determined else NOT_DETERMINED


def determinacy_sentence(first: int, second: int, words: Words, fov_range_deg: tuple[float, float]) -> str:
    """One sentence (1-based view numbers) that the agent's offline answerer reads back. The step's
    heading range (0 = forward, + = right, as camera_motion's angle_deg) goes with its words."""
    moves = [d for d in words.directions if d != NO_MOVEMENT]
    if not moves:
        moved = "stayed in place"
    else:
        moved = "moved " + " or ".join(moves)
        if len(moves) < len(words.directions):
            moved += " or stayed in place"
    mark = _mark(len(words.directions) == 1)
    if words.heading_range_deg is not None:
        low, high = (round(end) for end in words.heading_range_deg)
        mark = f"{mark[:-1]}; heading {low} to {high} degrees, 0 = forward, + = right)"
    low, high = fov_range_deg
    fovs = f"{round(low)} to {round(high)} degrees" if round(high) != round(low) else f"{round(low)} degrees"
    turn = turn_words(words.turns, words.yaw_range_deg)
    return (
        f"From view {first + 1} to view {second + 1} the camera {turn} {_mark(len(words.turns) == 1)} "
        f"and {moved} {mark}, over every horizontal field of view the photos allow ({fovs}; the focal "
        "length is unknown)."
    )


def with_motion_over_focal(
    motion: CameraMotion | UnknownMotion, hypotheses: FocalHypotheses | None
) -> CameraMotion | UnknownMotion:
    """A described pair with its motion over the focal hypotheses (and their sentence), if any."""
    if hypotheses is None or not isinstance(motion, CameraMotion):
        return motion
    pair = hypotheses.for_pair(motion.from_view, motion.to_view)
    if pair is None or not pair.fov_deg:
        # The poses are the central hypothesis's; without this pair's own, nothing says what holds.
        reason = (
            "the focal length is unknown and this pair was not solved over its range (too few shared matches)"
        )
        return unknown_motion(motion.from_view, motion.to_view, reason)
    over = motion_over_focal(pair)
    fields = {k: v for k, v in over.to_dict().items() if k not in ("from_view", "to_view")}
    return replace(motion, over_focal=fields, sentence=over.sentence)


__all__ = [
    "DETERMINED",
    "FOCAL_HYPOTHESIS_REASON",
    "NOT_DETERMINED",
    "FocalHypotheses",
    "Words",
    "circular_range",
    "hypothesis_motions",
    "MotionOverFocal",
    "PairHypotheses",
    "determinacy_sentence",
    "motion_over_focal",
    "turn_words",
    "with_motion_over_focal",
]
