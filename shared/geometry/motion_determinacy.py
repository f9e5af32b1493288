"""Which parts of a pair's camera motion the photos determine when the focal length is unknown.

Two photos of unknown focal fit a range of focal lengths almost equally well, and the relative pose
changes with the focal. A backbone then solves the pair at each plausible horizontal field of view
(a hypothesis) and keeps those the matches support. Here each hypothesis's relative pose is read
with the rules of camera_motion.py (same compass, same thresholds) in the first view's image axes,
and each quantity of the vocabulary (QUANTITIES: turn, tilt, roll, the compass step and its
left/right and forward/backward axes, the vertical step, stayed still) is *determined* when every
supported hypothesis gives it the same word: "turned left by 12 to 42 degrees (determined) and
moved forward or diagonally forward and left (not determined; ...); it made no vertical step
(determined); it tilted up by 6 to 56 degrees (determined); ...". Each carries its range.

The image axes, not a gravity frame: two cameras do not fix a scene up at every focal (the up
they suggest is the normal to their x axes, against which a roll is zero by construction), while
a person looking at the photos reads up, left and forward in them, as MMSI's annotators did.

A hypothesis is the relative pose x_second = R x_first + t (camera axes of the first view, OpenCV),
t a unit vector or zero (pure rotation), as two-view geometry gives it. Closer to / farther from a
target is not read over the hypotheses: they carry no points, and the step has no scale.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import numpy as np

from shared.geometry.camera_motion import (
    IMAGE_FRAME,
    NO_MOVEMENT,
    CameraMotion,
    FrameMotion,
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
NO_TILT_WORDS = "did not tilt significantly"
NO_ROLL_WORDS = "did not roll significantly"
NO_HORIZONTAL_STEP = "made no horizontal step"
NO_VERTICAL_STEP = "made no vertical step"


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
    # Set when an assumption about the scene (not the matches) dropped some hypotheses: its words.
    narrowed_by: str | None = None

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
        return cls(
            list(data["tested_fov_deg"]), float(data["central_fov_deg"]), pairs, data.get("narrowed_by")
        )


@dataclass(frozen=True)
class QuantityOverFocal:
    """One quantity of the motion vocabulary (turn, tilt, roll, a step's axis, ...) over every
    supported hypothesis: its distinct words, its range, and whether every hypothesis agrees."""

    words: list[str]  # distinct, in hypothesis order; "none" where a hypothesis says nothing of it
    range: tuple[float, float] | None  # degrees for angles; unit-step share for steps; None if no number
    determined: bool

    def to_dict(self) -> dict[str, object]:
        return {
            "words": list(self.words),
            "range": None if self.range is None else list(self.range),
            "determined": self.determined,
        }


# The vocabulary's quantities, in the order the sentence says them (the image frame: view i's axes).
QUANTITIES = ("turn", "tilt", "roll", "direction", "lateral", "depth", "vertical", "still")


@dataclass(frozen=True)
class MotionOverFocal:
    """A pair's motion over every supported hypothesis, and which words all of them share.

    Read in the first view's image axes (what a person looking at the photos calls left, up and
    forward): two cameras cannot fix a gravity frame at every focal. `quantities` has every
    quantity of the vocabulary (QUANTITIES); the older flat fields repeat turn, direction and
    vertical."""

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
    frame: str = IMAGE_FRAME
    quantities: dict[str, QuantityOverFocal] = field(default_factory=dict)
    fov_assumption: str | None = None  # what ruled out the narrower fields of view, if a scene prior did

    def to_dict(self) -> dict[str, object]:
        result = asdict(self)
        result["fov_range_deg"] = list(self.fov_range_deg)
        result["yaw_range_deg"] = list(self.yaw_range_deg)
        result["heading_range_deg"] = None if self.heading_range_deg is None else list(self.heading_range_deg)
        result["quantities"] = {name: quantity.to_dict() for name, quantity in self.quantities.items()}
        return result


def _distinct(values: list[str]) -> list[str]:
    return list(dict.fromkeys(values))


def _side(value: float, threshold: float, positive: str, negative: str) -> str:
    if abs(value) < threshold:
        return "none"
    return positive if value > 0 else negative


def turn_words(turns: list[str], yaw_range_deg: tuple[float, float]) -> str:
    """The turn clause: a side with its range when one side holds, else the signed range."""
    return _angle_clause("turned", turns, yaw_range_deg, ("left", "right"), NO_TURN_WORDS)


def _angle_clause(
    verb: str, sides: list[str], ends: tuple[float, float], names: tuple[str, str], none: str
) -> str:
    """'tilted up by 6 to 9 degrees', 'tilted between 3 degrees down and 6 degrees up', or `none`."""
    low, high = ends
    if sides == ["none"]:
        return none
    if len(sides) == 1:
        magnitudes = sorted((abs(low), abs(high)))
        if round(magnitudes[1]) - round(magnitudes[0]) < 1:
            return f"{verb} {sides[0]} by about {round(magnitudes[1])} degrees"
        return f"{verb} {sides[0]} by {round(magnitudes[0])} to {round(magnitudes[1])} degrees"

    def side(value: float) -> str:
        return f"{round(abs(value))} degrees {names[0] if value > 0 else names[1]}"

    return f"{verb} between {side(low)} and {side(high)}"


def circular_range(angles_deg: list[float]) -> tuple[float, float]:
    """The smallest signed interval holding every angle (degrees), measured from the first one:
    (170, -175) gives (170, 185), not (-175, 170)."""
    reference = angles_deg[0]
    offsets = [(angle - reference + 180.0) % 360.0 - 180.0 for angle in angles_deg]
    return float(reference + min(offsets)), float(reference + max(offsets))


def hypothesis_motions(
    hypotheses: PairHypotheses, threshold: float = 0.05, rotation_threshold_deg: float = 10.0
) -> list[CameraMotion]:
    """camera_motion's description of each hypothesis's relative pose (its `image` frame is read)."""
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


def _quantity(words: list[str], values: list[float] | None, circular: bool = False) -> QuantityOverFocal:
    distinct = _distinct(words)
    span = None
    if values:
        span = circular_range(values) if circular else (float(min(values)), float(max(values)))
    return QuantityOverFocal(distinct, span, len(distinct) == 1)


def _axis_word(direction: str, positive: str, negative: str) -> str:
    """'left' of 'diagonally forward and left': one axis of a compass direction, or "none"."""
    words = direction.replace("back ", "backward ").split()
    return next((word for word in (positive, negative) if word in words), "none")


def image_quantities(
    motions: list[CameraMotion], limits: tuple[float, float]
) -> dict[str, QuantityOverFocal]:
    """Every quantity of the vocabulary over the hypotheses, in the first view's image axes.
    `limits`: (turn threshold, tilt and roll threshold) in degrees."""
    frames: list[FrameMotion] = [m.image for m in motions if m.image is not None]
    turn_limit, tilt_limit = limits
    moved = [f for f in frames if f.direction != NO_MOVEMENT]
    return {
        "turn": _quantity(
            [_side(f.turn_deg, turn_limit, "left", "right") for f in frames],
            [f.turn_deg for f in frames],
            circular=True,
        ),
        "tilt": _quantity(
            [_side(f.tilt_deg, tilt_limit, "up", "down") for f in frames], [f.tilt_deg for f in frames]
        ),
        "roll": _quantity(
            [_side(f.roll_deg, tilt_limit, "clockwise", "counterclockwise") for f in frames],
            [f.roll_deg for f in frames],
            circular=True,
        ),
        "direction": _quantity(
            [f.direction for f in frames],
            [float(np.degrees(np.arctan2(f.right, f.forward))) for f in moved],
            circular=True,
        ),
        "lateral": _quantity(
            [_axis_word(f.direction, "right", "left") for f in frames], [f.right for f in frames]
        ),
        "depth": _quantity(
            [_axis_word(f.direction, "forward", "backward") for f in frames], [f.forward for f in frames]
        ),
        "vertical": _quantity([f.vertical_direction or "none" for f in frames], [f.up for f in frames]),
        "still": _quantity(["still" if m.still else "moved" for m in motions], None),
    }


def motion_over_focal(
    hypotheses: PairHypotheses,
    threshold: float = 0.05,
    rotation_threshold_deg: float = 10.0,
    tilt_threshold_deg: float = 5.0,
    fov_assumption: str | None = None,
) -> MotionOverFocal:
    """The pair's motion at every hypothesis and what they all agree on (see the module docstring).
    `fov_assumption`: what ruled out the fields of view missing from the hypotheses, when an
    assumption about the scene did (FocalHypotheses.narrowed_by); the sentence says it.

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
    quantities = image_quantities(motions, (rotation_threshold_deg, tilt_threshold_deg))
    turn, direction, vertical = quantities["turn"], quantities["direction"], quantities["vertical"]
    fov_range = (float(min(hypotheses.fov_deg)), float(max(hypotheses.fov_deg)))
    assert turn.range is not None
    return MotionOverFocal(
        from_view=hypotheses.first,
        to_view=hypotheses.second,
        hypotheses=len(hypotheses.fov_deg),
        fov_range_deg=fov_range,
        yaw_range_deg=turn.range,
        turns=turn.words,
        turn_determined=turn.determined,
        directions=direction.words,
        direction_determined=direction.determined,
        vertical_directions=vertical.words,
        vertical_determined=vertical.determined,
        translation_directions=steps,
        sentence=determinacy_sentence(
            hypotheses.first, hypotheses.second, quantities, fov_range, fov_assumption
        ),
        fov_assumption=fov_assumption,
        heading_range_deg=direction.range,
        quantities=quantities,
    )


def _mark(determined: bool) -> str:
    return DETERMINED if determined else NOT_DETERMINED


def _horizontal_clause(direction: QuantityOverFocal, still: QuantityOverFocal) -> str:
    """'moved forward or diagonally forward and left (not determined; heading -45 to 0 degrees, ...)'."""
    moves = [d for d in direction.words if d != NO_MOVEMENT]
    nothing = "stayed in place" if still.words == ["still"] else NO_HORIZONTAL_STEP
    if not moves:
        moved = nothing
    else:
        moved = "moved " + " or ".join(moves)
        if len(moves) < len(direction.words):
            moved += f" or {nothing}"
    mark = _mark(direction.determined)
    if direction.range is not None:
        # Left-positive, as every horizontal angle a person or a program reads (the range's own
        # numbers are camera_motion's right-positive heading).
        low, high = (round(-end) for end in reversed(direction.range))
        mark = f"{mark[:-1]}; heading {low} to {high} degrees, 0 = forward, + = left)"
    return f"{moved} {mark}"


def _vertical_clause(vertical: QuantityOverFocal) -> str:
    words = [f"moved {w}" if w != "none" else NO_VERTICAL_STEP for w in vertical.words]
    return f"{' or '.join(words)} {_mark(vertical.determined)}"


def determinacy_sentence(
    first: int,
    second: int,
    quantities: dict[str, QuantityOverFocal],
    fov_range_deg: tuple[float, float],
    fov_assumption: str | None = None,
) -> str:
    """One sentence (1-based view numbers, view `first`'s image axes) that the agent's offline
    answerer reads back (services/agent/motion_clue.py): each quantity with its range and its mark.
    The step's heading range goes with it, left-positive (0 = forward, + = left) like every
    horizontal angle on the wire."""
    turn, tilt, roll = (quantities[name] for name in ("turn", "tilt", "roll"))
    assert turn.range is not None and tilt.range is not None and roll.range is not None
    low, high = fov_range_deg
    fovs = f"{round(low)} to {round(high)} degrees" if round(high) != round(low) else f"{round(low)} degrees"
    if fov_assumption is not None:
        fovs += f", narrower ones ruled out by assuming that {fov_assumption}"
    turned = turn_words(turn.words, turn.range)
    tilted = _angle_clause("tilted", tilt.words, tilt.range, ("up", "down"), NO_TILT_WORDS)
    rolled = _angle_clause("rolled", roll.words, roll.range, ("clockwise", "counterclockwise"), NO_ROLL_WORDS)
    return (
        f"From view {first + 1} to view {second + 1} the camera {turned} {_mark(turn.determined)} "
        f"and {_horizontal_clause(quantities['direction'], quantities['still'])}; "
        f"it {_vertical_clause(quantities['vertical'])}; it {tilted} {_mark(tilt.determined)}; "
        f"it {rolled} {_mark(roll.determined)}; in view {first + 1}'s image axes, over every horizontal "
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
        # The poses are the central hypothesis's; without this pair's own, nothing says what holds.
        reason = (
            "the focal length is unknown and this pair was not solved over its range (too few shared matches)"
        )
        return unknown_motion(motion.from_view, motion.to_view, reason)
    over = motion_over_focal(pair, fov_assumption=hypotheses.narrowed_by)
    fields = {k: v for k, v in over.to_dict().items() if k not in ("from_view", "to_view")}
    return replace(motion, over_focal=fields, sentence=over.sentence)


__all__ = [
    "DETERMINED",
    "FOCAL_HYPOTHESIS_REASON",
    "NOT_DETERMINED",
    "FocalHypotheses",
    "QUANTITIES",
    "QuantityOverFocal",
    "image_quantities",
    "circular_range",
    "hypothesis_motions",
    "MotionOverFocal",
    "PairHypotheses",
    "determinacy_sentence",
    "motion_over_focal",
    "turn_words",
    "with_motion_over_focal",
]
