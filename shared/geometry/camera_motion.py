"""Describe how the camera moved between views, in numbers and in one English sentence.

Two frames, each stated in the sentence:
- **image** (default, always given): the first view's camera axes, what a person looking at the
  photos calls right, up and forward (x right, -y up, z forward of camera i). The step of camera
  j's centre in those axes is read on a compass in the x-z plane, its up component as "up" or
  "down"; the rotation from camera i to camera j is split into a turn (pan, about camera i's y
  axis, + = left), a tilt (pitch, + = up) and a roll about the new viewing direction (+ =
  clockwise as seen from behind the camera, looking where it looks: the photo's content then turns
  counterclockwise).
- **gravity**: the scene's up (given, or estimated from the cameras when their headings spread
  enough to fix it: `up_is_reliable`). The step is read on the horizontal compass of camera i's
  flat viewing direction plus the step along up; turn about up, tilt = the change of the viewing
  direction's elevation, roll = the change of the camera's roll against up. It is described when
  up is reliable; the sentence adds it only when its words differ from the image frame's (rolled
  photos, steeply pitched cameras).

- **the second view's image axes**: only the step, and only when the views rotated (a step
  "forward" in view 1's axes is "left" in view 2's after a right turn of 90 degrees). A rotation
  needs no second statement when it is about one axis: it leaves its own axis fixed, so that axis
  and its sense read the same in both views' axes (services/agent/asked_frame.py).

Compass: angle = atan2(right, forward), positive to the right; eight 45-degree sectors centred on
forward, diagonally forward and right, right, ... name it. The up/down step is said when it is at
least the distance threshold and at least 22.5 degrees above or below the compass plane (the
half-sector rule); steeper than 67.5 degrees it is only vertical ("moved up").

Thresholds (stated in every `CameraMotion.thresholds`): a step counts below `threshold *
scene_scale` as no movement; a turn below `rotation_threshold_deg` (10), a tilt or roll below
`tilt_threshold_deg` (5) as none. Below all of them the camera "stayed still". Without
`scene_scale` the scale is the robust extent of the camera centres, or 1.0 when they coincide
within 1e-9; callers that have points should pass `scene_scale=robust_extent(points)`.

Target: with `target` (a world point: a point, an object located by pixel, the scene's centre),
each pair also says whether camera j is closer to it than camera i ("came closer to", "moved
farther from"), by at least the distance threshold.

Lengths are said in the reconstruction's units: "0.42 m" in a metric one (`units="metres"`),
"0.42 scene units" in a relative one. Angles are rounded as people say them: to 1 degree below
10, to 5 below 30, to 15 from there on (43 -> 45, 88 -> 90).

Unknown motion: `describe_pairs` takes a reason per view that has no trustworthy pose (not
registered, uncertain) and returns, per pair, either a `CameraMotion` or an `UnknownMotion` that
says why; the motion of the other pairs is still described.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np

from shared.geometry.poses import estimate_up_axis, horizontal_forward, up_is_reliable, validate_extrinsic

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
IMAGE_FRAME = "image"
GRAVITY_FRAME = "gravity"
FRAME_NAMES = {IMAGE_FRAME: "in view {view}'s image axes", GRAVITY_FRAME: "in the scene's gravity frame"}
_COINCIDENT = 1e-9
_LEVEL_DEG = 22.5  # steeper than this, the vertical step is named
_STEEP_DEG = 67.5  # steeper than this, only the vertical step is named


@dataclass(frozen=True)
class FrameMotion:
    """The motion of one pair read in one frame (image: camera i's axes; gravity: the scene's up)."""

    frame: str  # IMAGE_FRAME or GRAVITY_FRAME
    right: float  # step along the frame's right, up and forward axes, in the reconstruction's units
    up: float
    forward: float
    direction: str  # compass direction in the right-forward plane, or NO_MOVEMENT
    vertical_direction: str | None  # "up", "down", or None when not significant
    turn_deg: float  # + = left
    tilt_deg: float  # + = up
    roll_deg: float  # + = clockwise as seen from behind the camera
    phrase: str  # e.g. "moved down and tilted up by about 8 degrees"


@dataclass(frozen=True)
class CameraMotion:
    from_view: int  # 0-based index
    to_view: int
    direction: str  # gravity frame, horizontal: one of DIRECTIONS or NO_MOVEMENT
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
    image: FrameMotion | None = None  # the first view's camera axes: what the sentence says first
    gravity: FrameMotion | None = None  # the scene's up, when it is reliable
    frames_differ: bool = False  # both frames are in the sentence
    still: bool = False  # below every threshold
    thresholds: dict[str, float] | None = None
    target_change: str | None = None  # "closer", "farther", "same distance", or None without a target
    target_distances: tuple[float, float] | None = None  # camera i's and j's distances to the target
    # Unknown focal: the motion over every supported focal hypothesis (motion_determinacy.py's
    # MotionOverFocal.to_dict()); the numbers above are those of the central hypothesis.
    over_focal: dict[str, object] | None = None

    def to_dict(self) -> dict[str, object]:
        """JSON-able dictionary (plain floats, ints, strings and lists)."""
        result = asdict(self)
        result["displacement_in_first_camera"] = list(self.displacement_in_first_camera)
        if self.target_distances is not None:
            result["target_distances"] = list(self.target_distances)
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


@dataclass(frozen=True)
class _Limits:
    distance: float  # in the reconstruction's units
    turn_deg: float
    tilt_deg: float  # tilt and roll
    units: str

    def as_dict(self, scene_scale: float, fraction: float) -> dict[str, float]:
        return {
            "distance": self.distance,
            "distance_fraction_of_scene": fraction,
            "scene_scale": scene_scale,
            "turn_deg": self.turn_deg,
            "tilt_deg": self.tilt_deg,
            "roll_deg": self.tilt_deg,
        }


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
    """Round an angle's magnitude as people say it: to 1 degree below 10, 5 below 30, 15 above."""
    magnitude = abs(angle_deg)
    step = 1.0 if magnitude < 9.5 else 5.0 if magnitude < 30.0 else 15.0
    return int(step * np.round(magnitude / step))


def describe_turn(yaw_deg: float, rotation_threshold_deg: float = 10.0) -> str:
    if abs(yaw_deg) < rotation_threshold_deg:
        return NO_ROTATION
    rounded = round_turn(yaw_deg)
    if rounded >= 180:
        return "turned around by about 180 degrees"
    return f"turned {'left' if yaw_deg > 0 else 'right'} by about {rounded} degrees"


def describe_tilt(tilt_deg: float, threshold_deg: float = 5.0) -> str | None:
    if abs(tilt_deg) < threshold_deg:
        return None
    return f"tilted {'up' if tilt_deg > 0 else 'down'} by about {round_turn(tilt_deg)} degrees"


def describe_roll(roll_deg: float, threshold_deg: float = 5.0) -> str | None:
    if abs(roll_deg) < threshold_deg:
        return None
    side = "clockwise" if roll_deg > 0 else "counterclockwise"
    return f"rolled {side} by about {round_turn(roll_deg)} degrees"


def _signed_angle(first: np.ndarray, second: np.ndarray, axis: np.ndarray) -> float:
    """Angle from `first` to `second` about `axis`, right-handed, degrees in (-180, 180]."""
    return float(np.degrees(np.arctan2(np.dot(axis, np.cross(first, second)), np.dot(first, second))))


def _wrap(angle_deg: float) -> float:
    return float((angle_deg + 180.0) % 360.0 - 180.0)


def _length(value: float, units: str) -> str:
    return f"{abs(value):.2f} {'m' if units == 'metres' else 'scene units'}"


def _step_words(
    right: float, up: float, forward: float, limits: _Limits
) -> tuple[str, str | None, float, float]:
    """(compass direction or NO_MOVEMENT, "up"/"down"/None, compass angle, flat distance)."""
    angle = float(np.degrees(np.arctan2(right, forward)))
    distance = float(np.hypot(right, forward))
    elevation = float(np.degrees(np.arctan2(abs(up), distance)))
    moved = distance >= limits.distance and elevation < _STEEP_DEG
    direction = direction_name(angle) if moved else NO_MOVEMENT
    vertical = None
    if abs(up) >= limits.distance and elevation >= _LEVEL_DEG:
        vertical = "up" if up > 0 else "down"
    return direction, vertical, angle, distance


def _phrase(
    step: tuple[str, str | None, float, float], rotations: list[str], axes: np.ndarray, units: str
) -> str:
    """'moved down and tilted up by about 8 degrees (a step of 0.09 scene units)', 'stayed in place
    and ...'; a metric step says its lengths inline ('moved 0.42 m forward and 0.15 m up')."""
    direction, vertical_word, _, distance = step
    metric = units == "metres"
    parts = []
    if direction != NO_MOVEMENT:
        parts.append(f"{_length(distance, units)} {direction}" if metric else direction)
    if vertical_word is not None:
        parts.append(f"{_length(axes[1], units)} {vertical_word}" if metric else vertical_word)
    moved = "moved " + " and ".join(parts) if parts else ""
    size = "" if metric or not moved else f" (a step of {_length(float(np.linalg.norm(axes)), units)})"
    if not rotations:
        return f"{moved} without turning significantly{size}" if moved else ""
    turned = rotations[0] if len(rotations) == 1 else ", ".join(rotations[:-1]) + " and " + rotations[-1]
    if not moved:
        return f"stayed in place and {turned}"
    joined = (
        f"{moved}, and {turned}"
        if vertical_word is not None or len(rotations) > 1
        else f"{moved} and {turned}"
    )
    return joined + size


def _rotation_words(turn_deg: float, tilt_deg: float, roll_deg: float, limits: _Limits) -> list[str]:
    turn = describe_turn(turn_deg, limits.turn_deg)
    words = [] if turn == NO_ROTATION else [turn]
    return words + [
        w for w in (describe_tilt(tilt_deg, limits.tilt_deg), describe_roll(roll_deg, limits.tilt_deg)) if w
    ]


def _frame_motion(
    frame: str, axes: tuple[float, float, float], angles: tuple[float, float, float], limits: _Limits
) -> FrameMotion:
    right, up, forward = axes
    step = _step_words(right, up, forward, limits)
    rotations = _rotation_words(*angles, limits)
    return FrameMotion(
        frame=frame,
        right=right,
        up=up,
        forward=forward,
        direction=step[0],
        vertical_direction=step[1],
        turn_deg=angles[0],
        tilt_deg=angles[1],
        roll_deg=angles[2],
        phrase=_phrase(step, rotations, np.array(axes), limits.units),
    )


def _image_rotation(first: np.ndarray, second: np.ndarray) -> tuple[float, float, float]:
    """(turn + left, tilt + up, roll + clockwise) of camera j seen in camera i's axes."""
    axes = first[:3, :3] @ second[:3, :3].T  # camera j's axes (columns) in camera i's coordinates
    forward, right = axes[:, 2], axes[:, 0]
    turn = float(np.degrees(np.arctan2(-forward[0], forward[2])))
    tilt = float(np.degrees(np.arctan2(-forward[1], np.hypot(forward[0], forward[2]))))
    return turn, tilt, _roll(forward, right, np.array([0.0, -1.0, 0.0]))


def _roll(forward: np.ndarray, right: np.ndarray, up: np.ndarray) -> float:
    """Roll of a camera (its forward and right axes) against `up`: + = its right side went down."""
    level = np.cross(forward, up)  # a camera without roll has this as its right axis
    if np.linalg.norm(level) < 1e-6:  # looking straight along up: roll is undefined, say none
        return 0.0
    return _signed_angle(level / np.linalg.norm(level), right, forward)


def _gravity_rotation(first: np.ndarray, second: np.ndarray, up: np.ndarray) -> tuple[float, float, float]:
    turn = _signed_angle(horizontal_forward(first[:3, :3], up), horizontal_forward(second[:3, :3], up), up)
    elevation = [
        float(np.degrees(np.arcsin(np.clip(pose[2, :3] @ up, -1.0, 1.0)))) for pose in (first, second)
    ]
    rolls = [_roll(pose[2, :3], pose[0, :3], up) for pose in (first, second)]
    return turn, elevation[1] - elevation[0], _wrap(rolls[1] - rolls[0])


def _signature(frame: FrameMotion, limits: _Limits) -> tuple[str, ...]:
    """What a frame's words say, without the numbers: to tell whether two frames disagree."""
    turn = describe_turn(frame.turn_deg, limits.turn_deg).split(" by ")[0]
    tilt = (describe_tilt(frame.tilt_deg, limits.tilt_deg) or "").split(" by ")[0]
    roll = (describe_roll(frame.roll_deg, limits.tilt_deg) or "").split(" by ")[0]
    return (frame.direction, str(frame.vertical_direction), turn, tilt, roll)


def _target_change(
    centers: tuple[np.ndarray, np.ndarray], target: np.ndarray | None, limits: _Limits
) -> tuple[str | None, tuple[float, float] | None]:
    if target is None:
        return None, None
    before, after = (float(np.linalg.norm(c - target)) for c in centers)
    if after <= before - limits.distance:
        return "closer", (before, after)
    return ("farther" if after >= before + limits.distance else "same distance"), (before, after)


def _still_words(limits: _Limits) -> str:
    return (
        f"stayed still: no step of {_length(limits.distance, limits.units)} or more, no turn of "
        f"{limits.turn_deg:g} degrees or more, no tilt or roll of {limits.tilt_deg:g} degrees or more"
    )


_TARGET_WORDS = {
    "closer": "came closer to",
    "farther": "moved farther from",
    "same distance": "stayed as far from",
}


def _end_axes_step(
    second: np.ndarray, step_world: np.ndarray, image: FrameMotion, limits: _Limits
) -> str | None:
    """'moved right': the step in the second view's own image axes, when the views rotated (else
    the first view's axes say it within the thresholds) and the camera stepped."""
    rotated = _rotation_words(image.turn_deg, image.tilt_deg, image.roll_deg, limits)
    stepped = image.direction != NO_MOVEMENT or image.vertical_direction is not None
    if not (rotated and stepped):
        return None
    d = second[:3, :3] @ step_world
    direction, vertical, _, _ = _step_words(float(d[0]), float(-d[1]), float(d[2]), limits)
    parts = [word for word in (None if direction == NO_MOVEMENT else direction, vertical) if word]
    return "moved " + " and ".join(parts) if parts else "made no significant step"


def _sentence(
    indices: tuple[int, int],
    frames: tuple[FrameMotion, FrameMotion | None],
    limits: _Limits,
    target: tuple[str | None, tuple[float, float] | None, str],
    end_step: str | None = None,
) -> str:
    """'From view 1 to view 2, in view 1's image axes, the camera moved ...; in the scene's gravity
    frame it ...; in view 2's image axes it moved ...; it came closer to the target (0.90 to 0.60
    scene units).'"""
    first, second = indices
    image, gravity = frames
    frame = FRAME_NAMES[IMAGE_FRAME].format(view=first + 1)
    body = image.phrase or _still_words(limits)
    sentence = f"From view {first + 1} to view {second + 1}, {frame}, the camera {body}"
    if gravity is not None:
        sentence += f"; {FRAME_NAMES[GRAVITY_FRAME]} it {gravity.phrase or 'stayed still'}"
    if end_step is not None:
        sentence += f"; {FRAME_NAMES[IMAGE_FRAME].format(view=second + 1)} it {end_step}"
    change, distances, name = target
    if change is not None and distances is not None:
        before, after = (_length(d, limits.units) for d in distances)
        sentence += f"; it {_TARGET_WORDS[change]} {name} ({before} to {after})"
    return sentence + "."


def _motion(
    poses: tuple[np.ndarray, np.ndarray],
    indices: tuple[int, int],
    up: tuple[np.ndarray, bool],
    limits: _Limits,
    target: tuple[np.ndarray | None, str],
) -> CameraMotion:
    first, second = poses
    up_axis, reliable = up
    rotation = first[:3, :3]
    centers = tuple(-pose[:3, :3].T @ pose[:3, 3] for pose in poses)
    step_world = centers[1] - centers[0]
    d = rotation @ step_world
    image = _frame_motion(
        IMAGE_FRAME, (float(d[0]), float(-d[1]), float(d[2])), _image_rotation(first, second), limits
    )
    vertical = float(step_world @ up_axis)
    forward = horizontal_forward(rotation, up_axis)
    right = np.cross(forward, up_axis)  # for a level camera this is its +x axis
    gravity_axes = (float(step_world @ right), vertical, float(step_world @ forward))
    gravity = _frame_motion(GRAVITY_FRAME, gravity_axes, _gravity_rotation(first, second, up_axis), limits)
    differ = reliable and _signature(gravity, limits) != _signature(image, limits)
    direction, vertical_direction, angle, distance = _step_words(*gravity_axes, limits)
    change, distances = _target_change(centers, target[0], limits)
    still = image.phrase == ""
    return CameraMotion(
        from_view=indices[0],
        to_view=indices[1],
        direction=direction,
        angle_deg=angle,
        distance=distance,
        vertical=vertical,
        displacement_in_first_camera=(float(d[0]), float(d[1]), float(d[2])),
        yaw_deg=gravity.turn_deg,
        turn=describe_turn(gravity.turn_deg, limits.turn_deg),
        sentence=_sentence(
            indices,
            (image, gravity if differ else None),
            limits,
            (change, distances, target[1]),
            _end_axes_step(second, step_world, image, limits),
        ),
        vertical_direction=vertical_direction,
        units=limits.units,
        image=image,
        gravity=gravity if reliable else None,
        frames_differ=differ,
        still=still,
        target_change=change,
        target_distances=distances,
    )


def _up_axis(stack: np.ndarray, up: np.ndarray | None, up_reliable: bool | None) -> tuple[np.ndarray, bool]:
    if up is None:
        reliable = up_is_reliable(stack) if up_reliable is None else up_reliable
        return estimate_up_axis(stack), reliable
    up_axis = np.asarray(up, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(up_axis)) or np.linalg.norm(up_axis) < 1e-12:
        raise ValueError("up must be a finite non-zero 3-vector")
    return up_axis / np.linalg.norm(up_axis), True if up_reliable is None else up_reliable


def _checked_target(target: np.ndarray | None) -> np.ndarray | None:
    if target is None:
        return None
    point = np.asarray(target, dtype=np.float64).reshape(-1)
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise ValueError("target must be a finite 3-vector (a world point)")
    return point


def describe_camera_motion(
    extrinsics: np.ndarray,
    pairs: list[tuple[int, int]] | None = None,
    up: np.ndarray | None = None,
    scene_scale: float | None = None,
    threshold: float = 0.05,
    rotation_threshold_deg: float = 10.0,
    units: str = "relative",
    *,
    tilt_threshold_deg: float = 5.0,
    up_reliable: bool | None = None,
    target: np.ndarray | None = None,
    target_name: str = "the target",
    view_numbers: Sequence[int] | None = None,
) -> list[CameraMotion]:
    """Motion for each pair of views (default: consecutive views), see the module docstring.

    `up_reliable`: whether the gravity frame is described (default: True for a given `up`, else
    whether the cameras' headings fix it, `up_is_reliable`). `view_numbers`: the 0-based index each
    pose is known by (default: its position), for the sentences and `from_view` / `to_view`.
    """
    stack = np.asarray(extrinsics, dtype=np.float64)
    if stack.ndim != 3 or stack.shape[1:] not in ((3, 4), (4, 4)):
        raise ValueError(f"extrinsics must be (V, 3, 4) or (V, 4, 4), got shape {stack.shape}")
    if units not in UNITS:
        raise ValueError(f"units must be one of {UNITS}, not {units!r}")
    poses = [validate_extrinsic(pose) for pose in stack]
    views = len(poses)
    if pairs is None:
        pairs = [(index, index + 1) for index in range(views - 1)]
    for pair in pairs:
        if len(pair) != 2 or not all(0 <= int(v) < views for v in pair):
            raise ValueError(f"pair {tuple(pair)} is out of range for {views} views")
    up_frame = _up_axis(stack, up, up_reliable)
    if scene_scale is None:
        extent = robust_extent(np.stack([-pose[:3, :3].T @ pose[:3, 3] for pose in poses]))
        scene_scale = extent if extent > _COINCIDENT else 1.0
    if not np.isfinite(scene_scale) or scene_scale <= 0:
        raise ValueError(f"scene_scale must be positive and finite, got {scene_scale}")
    limits = _Limits(threshold * scene_scale, rotation_threshold_deg, tilt_threshold_deg, units)
    stated = limits.as_dict(float(scene_scale), threshold)
    aim = (_checked_target(target), target_name)
    names = list(range(views)) if view_numbers is None else [int(v) for v in view_numbers]
    return [
        replace(_motion((poses[i], poses[j]), (names[i], names[j]), up_frame, limits, aim), thresholds=stated)
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
    **options: object,
) -> list[CameraMotion | UnknownMotion]:
    """Per pair a description, or why there is none (`view_problems[i]`: why view i has no usable pose).

    Pairs default to `default_pairs`. Up and the scale come from the usable views only. `options`
    go to `describe_camera_motion` (tilt_threshold_deg, up_reliable, target, target_name).
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
            view_numbers=placed,
            **options,  # type: ignore[arg-type]
        )
        described = dict(zip(good_pairs, motions, strict=True))
    results: list[CameraMotion | UnknownMotion] = []
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
    "FRAME_NAMES",
    "GRAVITY_FRAME",
    "IMAGE_FRAME",
    "CameraMotion",
    "FrameMotion",
    "UnknownMotion",
    "default_pairs",
    "describe_camera_motion",
    "describe_pairs",
    "describe_roll",
    "describe_tilt",
    "describe_turn",
    "direction_name",
    "robust_extent",
    "round_turn",
    "unknown_motion",
]
