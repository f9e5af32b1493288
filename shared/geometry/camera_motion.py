"""Describe how the camera moved between views, in numbers and in one English sentence.

For a pair (i, j) the centre of camera j is expressed in camera i's frame, its up component (scene
up, seen from camera i) is removed, and the rest is read on a horizontal compass whose "forward" is
camera i's viewing direction laid flat: angle = atan2(right, forward), positive to the right.
Eight 45-degree sectors centred on forward, diagonally forward and right, right, ... name it.

Scale: reconstructions have arbitrary units, so "no significant movement" is relative:
horizontal displacement < threshold * scene_scale. Without `scene_scale` the scale is the robust
extent of the camera centres (twice the 90th percentile of their distances to the median centre),
or 1.0 when the centres coincide within 1e-9. Callers that have points should pass
`scene_scale=robust_extent(points)`: with only two cameras the centres alone cannot tell a small
jitter from a real step.

Vertical: the step along up is said ("and up", "and down") when it is significant, i.e. at least
`threshold * scene_scale` and at least 22.5 degrees above or below the horizontal (the half-sector
rule of the compass). A step steeper than 67.5 degrees is only vertical ("moved up").

Unknown motion: `describe_pairs` takes a reason per view that has no trustworthy pose (not
registered, uncertain) and returns, per pair, either a `CameraMotion` or an `UnknownMotion` that
says why; the motion of the other pairs is still described.

Units: in a metric reconstruction (`units="metres"`: Pi3X, posed RGB-D) the sentence says how far
("moved 0.42 m forward", "and 0.15 m up"); in a relative one (`units="relative"`) only the
direction, since a length in scene units means nothing to a reader.

Turn: the signed angle about up from camera i's flat viewing direction to camera j's, positive =
left. It is rounded to 5 degrees below 30 degrees and to 15 degrees from there on (so 43 -> 45,
88 -> 90); below `rotation_threshold_deg` (10) it is "no significant rotation".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np

from shared.geometry.poses import estimate_up_axis, horizontal_forward, validate_extrinsic

DIRECTIONS = (
    "forward",
    "diagonally forward and right",
    "right",
    "diagonally back and right",
    "backward",
    "diagonally back and left",
    "left",
    "diagonally forward and left",
)
NO_MOVEMENT = "no significant movement"
UNITS = ("metres", "relative")
NO_ROTATION = "no significant rotation"
_COINCIDENT = 1e-9
_LEVEL_DEG = 22.5  # steeper than this, the vertical step is named
_STEEP_DEG = 67.5  # steeper than this, only the vertical step is named


@dataclass(frozen=True)
class CameraMotion:
    from_view: int  # 0-based index
    to_view: int
    direction: str  # horizontal: one of DIRECTIONS or NO_MOVEMENT
    angle_deg: float  # horizontal heading of the move in the first camera, 0 forward, +90 right
    distance: float  # horizontal distance, in `units`
    vertical: float  # displacement along up, positive = up
    displacement_in_first_camera: tuple[float, float, float]  # (x right, y down, z forward)
    yaw_deg: float  # turn about up, positive = left
    turn: str  # e.g. "turned left by about 45 degrees" or NO_ROTATION
    sentence: str
    vertical_direction: str | None = None  # "up", "down", or None when not significant
    described: bool = True
    units: str = "relative"  # of distance and vertical: "metres" or "relative" (scene units)
    # Unknown focal: the motion over every supported focal hypothesis (motion_determinacy.py's
    # MotionOverFocal.to_dict()); the numbers above are those of the central hypothesis.
    over_focal: dict[str, object] | None = None

    def to_dict(self) -> dict[str, object]:
        """JSON-able dictionary (plain floats, ints, strings and lists)."""
        result = asdict(self)
        result["displacement_in_first_camera"] = list(self.displacement_in_first_camera)
        return result


@dataclass(frozen=True)
class UnknownMotion:
    """A pair whose motion cannot be described, and why."""

    from_view: int
    to_view: int
    reason: str
    sentence: str
    described: bool = False

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


def robust_extent(points: np.ndarray) -> float:
    """Twice the 90th percentile distance of points to their median: a size robust to outliers."""
    cloud = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    cloud = cloud[np.all(np.isfinite(cloud), axis=1)]
    if len(cloud) == 0:
        return 0.0
    distances = np.linalg.norm(cloud - np.median(cloud, axis=0), axis=1)
    return float(2.0 * np.percentile(distances, 90))


def direction_name(angle_deg: float) -> str:
    """Compass name of a heading (0 = forward, positive = right); sectors are 45 degrees wide."""
    sector = int(np.floor((angle_deg + 22.5) / 45.0)) % 8
    return DIRECTIONS[sector]


def round_turn(angle_deg: float) -> int:
    """Round a turn magnitude as people say it: to 5 degrees below 30, to 15 degrees above."""
    magnitude = abs(angle_deg)
    step = 5.0 if magnitude < 30.0 else 15.0
    return int(step * np.round(magnitude / step))


def describe_turn(yaw_deg: float, rotation_threshold_deg: float = 10.0) -> str:
    if abs(yaw_deg) < rotation_threshold_deg:
        return NO_ROTATION
    rounded = round_turn(yaw_deg)
    if rounded >= 180:
        return "turned around by about 180 degrees"
    return f"turned {'left' if yaw_deg > 0 else 'right'} by about {rounded} degrees"


def _signed_angle(first: np.ndarray, second: np.ndarray, axis: np.ndarray) -> float:
    """Angle from `first` to `second` about `axis`, right-handed, degrees in (-180, 180]."""
    return float(np.degrees(np.arctan2(np.dot(axis, np.cross(first, second)), np.dot(first, second))))


def _metres(length: float) -> str:
    return f"{abs(length):.2f} m"


def _sentence(
    from_view: int,
    to_view: int,
    direction: str,
    turn: str,
    vertical: str | None = None,
    lengths: tuple[float, float] | None = None,
) -> str:
    """`lengths` (horizontal, vertical) in metres, said when given (metric reconstructions)."""
    turned = turn != NO_ROTATION
    head = f"From view {from_view + 1} to view {to_view + 1} the camera"
    if lengths is not None:
        direction = direction if direction == NO_MOVEMENT else f"{_metres(lengths[0])} {direction}"
        vertical = vertical if vertical is None else f"{_metres(lengths[1])} {vertical}"
    if vertical is not None:
        way = vertical if direction == NO_MOVEMENT else f"{direction} and {vertical}"
        if turned:
            return f"{head} moved {way}, and {turn}."
        return f"{head} moved {way} without turning significantly."
    moved = direction != NO_MOVEMENT
    if moved and turned:
        return f"{head} moved {direction} and {turn}."
    if moved:
        return f"{head} moved {direction} without turning significantly."
    if turned:
        return f"{head} stayed in place and {turn}."
    return f"{head} neither moved nor turned significantly."


def _motion(
    first: np.ndarray,
    second: np.ndarray,
    indices: tuple[int, int],
    up: np.ndarray,
    min_distance: float,
    rotation_threshold_deg: float,
    units: str = "relative",
) -> CameraMotion:
    rotation = first[:3, :3]
    center_first = -rotation.T @ first[:3, 3]
    center_second = -second[:3, :3].T @ second[:3, 3]
    step_world = center_second - center_first
    vertical = float(step_world @ up)
    flat = step_world - vertical * up
    forward = horizontal_forward(rotation, up)
    right = np.cross(forward, up)  # for a level camera this is its +x axis
    angle = float(np.degrees(np.arctan2(flat @ right, flat @ forward)))
    distance = float(np.linalg.norm(flat))
    elevation = float(np.degrees(np.arctan2(abs(vertical), distance)))
    direction = direction_name(angle) if distance >= min_distance and elevation < _STEEP_DEG else NO_MOVEMENT
    vertical_direction = None
    if abs(vertical) >= min_distance and elevation >= _LEVEL_DEG:
        vertical_direction = "up" if vertical > 0 else "down"
    yaw_deg = _signed_angle(forward, horizontal_forward(second[:3, :3], up), up)
    turn = describe_turn(yaw_deg, rotation_threshold_deg)
    displacement = rotation @ step_world
    return CameraMotion(
        from_view=indices[0],
        to_view=indices[1],
        direction=direction,
        angle_deg=angle,
        distance=distance,
        vertical=vertical,
        displacement_in_first_camera=(float(displacement[0]), float(displacement[1]), float(displacement[2])),
        yaw_deg=yaw_deg,
        turn=turn,
        sentence=_sentence(
            indices[0], indices[1], direction, turn, vertical_direction, _lengths(units, distance, vertical)
        ),
        vertical_direction=vertical_direction,
        units=units,
    )


def _lengths(units: str, distance: float, vertical: float) -> tuple[float, float] | None:
    if units not in UNITS:
        raise ValueError(f"units must be one of {UNITS}, not {units!r}")
    return (distance, vertical) if units == "metres" else None


def describe_camera_motion(
    extrinsics: np.ndarray,
    pairs: list[tuple[int, int]] | None = None,
    up: np.ndarray | None = None,
    scene_scale: float | None = None,
    threshold: float = 0.05,
    rotation_threshold_deg: float = 10.0,
    units: str = "relative",
) -> list[CameraMotion]:
    """Motion for each pair of views (default: consecutive views), see the module docstring."""
    stack = np.asarray(extrinsics, dtype=np.float64)
    if stack.ndim != 3 or stack.shape[1:] not in ((3, 4), (4, 4)):
        raise ValueError(f"extrinsics must be (V, 3, 4) or (V, 4, 4), got shape {stack.shape}")
    poses = [validate_extrinsic(pose) for pose in stack]
    views = len(poses)
    if pairs is None:
        pairs = [(index, index + 1) for index in range(views - 1)]
    for pair in pairs:
        if len(pair) != 2 or not all(0 <= int(v) < views for v in pair):
            raise ValueError(f"pair {tuple(pair)} is out of range for {views} views")
    if up is None:
        up_axis = estimate_up_axis(stack)
    else:
        up_axis = np.asarray(up, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(up_axis)) or np.linalg.norm(up_axis) < 1e-12:
            raise ValueError("up must be a finite non-zero 3-vector")
        up_axis = up_axis / np.linalg.norm(up_axis)
    if scene_scale is None:
        centers = np.stack([-pose[:3, :3].T @ pose[:3, 3] for pose in poses])
        extent = robust_extent(centers)
        scene_scale = extent if extent > _COINCIDENT else 1.0
    if not np.isfinite(scene_scale) or scene_scale <= 0:
        raise ValueError(f"scene_scale must be positive and finite, got {scene_scale}")
    min_distance = threshold * scene_scale
    return [
        _motion(poses[i], poses[j], (int(i), int(j)), up_axis, min_distance, rotation_threshold_deg, units)
        for i, j in pairs
    ]


def unknown_motion(from_view: int, to_view: int, reason: str) -> UnknownMotion:
    sentence = f"From view {from_view + 1} to view {to_view + 1} the camera motion is unknown: {reason}."
    return UnknownMotion(from_view=from_view, to_view=to_view, reason=reason, sentence=sentence)


def default_pairs(views: int, usable: Sequence[bool]) -> list[tuple[int, int]]:
    """Consecutive pairs, plus a pair bridging each run of unusable views (view 1 -> 3 when 2 is not)."""
    pairs = [(index, index + 1) for index in range(views - 1)]
    placed = [index for index in range(views) if usable[index]]
    for first, second in zip(placed, placed[1:], strict=False):
        if second - first > 1:
            pairs.append((first, second))
    return sorted(pairs)


def describe_pairs(
    extrinsics: np.ndarray,
    view_problems: Sequence[str | None],
    pairs: list[tuple[int, int]] | None = None,
    up: np.ndarray | None = None,
    scene_scale: float | None = None,
    threshold: float = 0.05,
    rotation_threshold_deg: float = 10.0,
    units: str = "relative",
) -> list[CameraMotion | UnknownMotion]:
    """Per pair a description, or why there is none (`view_problems[i]`: why view i has no usable pose).

    Pairs default to `default_pairs`. Up and the scale come from the usable views only.
    """
    stack = np.asarray(extrinsics, dtype=np.float64)
    views = len(stack)
    if len(view_problems) != views:
        raise ValueError(f"{len(view_problems)} view problems for {views} views")
    usable = [problem is None for problem in view_problems]
    if pairs is None:
        pairs = default_pairs(views, usable)
    for pair in pairs:
        if len(pair) != 2 or not all(0 <= int(v) < views for v in pair):
            raise ValueError(f"pair {tuple(pair)} is out of range for {views} views")
    placed = [index for index in range(views) if usable[index]]
    results: list[CameraMotion | UnknownMotion] = []
    described: dict[tuple[int, int], CameraMotion] = {}
    good_pairs = [(int(i), int(j)) for i, j in pairs if usable[i] and usable[j]]
    if good_pairs:
        position = {view: k for k, view in enumerate(placed)}
        motions = describe_camera_motion(
            stack[placed],
            pairs=[(position[i], position[j]) for i, j in good_pairs],
            up=up,
            scene_scale=scene_scale,
            threshold=threshold,
            rotation_threshold_deg=rotation_threshold_deg,
            units=units,
        )
        for (i, j), motion in zip(good_pairs, motions, strict=True):
            lengths = _lengths(units, motion.distance, motion.vertical)
            sentence = _sentence(i, j, motion.direction, motion.turn, motion.vertical_direction, lengths)
            described[(i, j)] = replace(motion, from_view=i, to_view=j, sentence=sentence)
    for i, j in pairs:
        i, j = int(i), int(j)
        if (i, j) in described:
            results.append(described[(i, j)])
        else:
            reasons = [view_problems[v] for v in dict.fromkeys((i, j)) if view_problems[v] is not None]
            results.append(unknown_motion(i, j, "; ".join(str(r) for r in reasons)))
    return results


__all__ = [
    "DIRECTIONS",
    "NO_MOVEMENT",
    "NO_ROTATION",
    "UNITS",
    "CameraMotion",
    "UnknownMotion",
    "default_pairs",
    "describe_camera_motion",
    "describe_pairs",
    "describe_turn",
    "direction_name",
    "robust_extent",
    "round_turn",
    "unknown_motion",
]
