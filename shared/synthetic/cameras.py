"""Camera rigs for MindCube's three settings, placed in a SyntheticScene.

All cameras stand at eye level (EYE_HEIGHT) and are OpenCV camera-from-world extrinsics.

- ``rotation``: one standing point (the room centre, kept free by the scene generator); the
  viewer turns in place by a fixed step, always the same way.
- ``around``: the viewer walks along an arc around an arrangement (an object and its nearest
  neighbour), every view looking at the arrangement's middle.
- ``among``: as in MindCube's "among" images (front / left / back / right of a central object),
  the viewer stands on the four sides of a central object, each view looking at it. "left" is
  the left side as seen from the front view, so going front -> left is a walk forward and left.

A rig returns None when the scene leaves no clear standing points for it; callers try another.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import open3d as o3d

from shared.synthetic.geometry import camera_centre
from shared.synthetic.render import look_at
from shared.synthetic.scene import SyntheticScene

EYE_HEIGHT = 1.5
_PITCH_DOWN_DEG = 12.0  # rotation rig: look a little down so the floor and furniture are in view
_CLEARANCE = 0.45  # metres between a standing point and any furniture footprint
_WALL_CLEARANCE = 0.6
SETTINGS = ("rotation", "around", "among")


@dataclass
class CameraRig:
    setting: str
    extrinsics: np.ndarray  # (V, 3, 4) camera-from-world
    view_names: list[str]
    facts: dict = field(default_factory=dict)  # how the rig was placed, for meta_info

    @property
    def centres(self) -> np.ndarray:
        return np.array([camera_centre(e) for e in self.extrinsics])


def _standing_point_is_clear(scene: SyntheticScene, xy: np.ndarray) -> bool:
    if np.any(xy < scene.room_min[:2] + _WALL_CLEARANCE) or np.any(xy > scene.room_max[:2] - _WALL_CLEARANCE):
        return False
    for obj in scene.objects:
        # Distance from the point to the object's axis-aligned footprint.
        gap = np.maximum(np.abs(xy - obj.centre[:2]) - obj.size[:2] / 2, 0.0)
        if np.linalg.norm(gap) < _CLEARANCE:
            return False
    return True


def _sees_object(scene: SyntheticScene, eye: np.ndarray, object_id: int) -> bool:
    """True when the ray from the eye to the object's centre first hits that object."""
    target = scene.objects[object_id].centre
    ray = np.concatenate([eye, target - eye]).astype(np.float32)[None]
    hits = scene.raycasting_scene.cast_rays(o3d.core.Tensor(ray))
    triangle = int(hits["primitive_ids"].numpy()[0])
    if not np.isfinite(hits["t_hit"].numpy()[0]):
        return False
    return int(scene.triangle_object_ids[triangle]) == object_id


def _eye(xy: np.ndarray) -> np.ndarray:
    return np.array([xy[0], xy[1], EYE_HEIGHT])


def _direction(yaw_deg: float) -> np.ndarray:
    return np.array([np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))])


def rotation_rig(
    scene: SyntheticScene, rng: np.random.Generator, num_views: int = 4, step_deg: float = 90.0
) -> CameraRig:
    """Turn in place at the room centre by ``step_deg`` per view, to the right or to the left."""
    eye = _eye(scene.room_centre[:2])
    start = float(rng.uniform(0.0, 360.0))
    turn_right = bool(rng.random() < 0.5)
    # With z up, a positive yaw about z is a left (counter-clockwise) turn seen from above.
    sign = -1.0 if turn_right else 1.0
    extrinsics, names = [], []
    drop = np.tan(np.radians(_PITCH_DOWN_DEG))
    for k in range(num_views):
        yaw = start + sign * step_deg * k
        target = eye + np.append(_direction(yaw), -drop)
        extrinsics.append(look_at(eye, target, scene.up))
        names.append(f"view{k}")
    facts = {"standing_point": eye.tolist(), "step_deg": step_deg, "turn": "right" if turn_right else "left"}
    return CameraRig("rotation", np.array(extrinsics), names, facts)


def around_rig(
    scene: SyntheticScene, rng: np.random.Generator, num_views: int = 3, attempts: int = 60
) -> CameraRig | None:
    """Walk an arc around an object and its nearest neighbour, always looking at their middle."""
    centres = scene.object_centres
    for _ in range(attempts):
        anchor = int(rng.integers(len(scene.objects)))
        distances = np.linalg.norm(centres[:, :2] - centres[anchor, :2], axis=1)
        distances[anchor] = np.inf
        partner = int(np.argmin(distances))
        members = [anchor] if distances[partner] > 2.5 else [anchor, partner]
        middle = centres[members].mean(axis=0)
        spread = max(scene.objects[m].footprint_radius for m in members) + 0.5 * len(members) - 0.5
        radius = spread + float(rng.uniform(1.4, 2.4))
        # Arc steps near 20 or 90 degrees put the walking direction mid-sector (about "right" or
        # "diagonally forward and right"), not on a 22.5-degree boundary, so motion is askable.
        step = float(rng.choice([20.0, 90.0]) + rng.uniform(-5.0, 5.0)) * (1 if rng.random() < 0.5 else -1)
        start = float(rng.uniform(0.0, 360.0))
        eyes = [_eye(middle[:2] + radius * _direction(start + step * k)) for k in range(num_views)]
        if not all(_standing_point_is_clear(scene, e[:2]) for e in eyes):
            continue
        if not all(_sees_object(scene, e, anchor) for e in eyes):
            continue
        look = np.array([middle[0], middle[1], 0.6])
        facts = {
            "arrangement": [scene.objects[m].name for m in members],
            "look_at": look.tolist(),
            "radius": radius,
            "arc_step_deg": abs(step),
            "walk": "counter-clockwise" if step > 0 else "clockwise",
        }
        extrinsics = np.array([look_at(e, look, scene.up) for e in eyes])
        return CameraRig("around", extrinsics, [f"view{k}" for k in range(num_views)], facts)
    return None


def among_rig(scene: SyntheticScene, rng: np.random.Generator, attempts: int = 60) -> CameraRig | None:
    """Stand on the front, left, back and right sides of a central object, looking at it."""
    for _ in range(attempts):
        central = int(rng.integers(len(scene.objects)))
        obj = scene.objects[central]
        distance = obj.footprint_radius + float(rng.uniform(1.2, 2.0))
        front_yaw = float(rng.uniform(0.0, 360.0))
        # The front camera looks along f; "left" stands at the front viewer's left of the object.
        forward = _direction(front_yaw)
        right = np.array([forward[1], -forward[0]])
        sides = {"front": -forward, "left": -right, "back": forward, "right": right}
        eyes = [_eye(obj.centre[:2] + distance * offset) for offset in sides.values()]
        if not all(_standing_point_is_clear(scene, e[:2]) for e in eyes):
            continue
        if not all(_sees_object(scene, e, central) for e in eyes):
            continue
        extrinsics = np.array([look_at(e, obj.centre, scene.up) for e in eyes])
        facts = {"central_object": obj.name, "distance": distance}
        return CameraRig("among", extrinsics, list(sides), facts)
    return None


def make_rig(setting: str, scene: SyntheticScene, rng: np.random.Generator) -> CameraRig | None:
    if setting == "rotation":
        return rotation_rig(scene, rng)
    if setting == "around":
        return around_rig(scene, rng, num_views=int(rng.integers(2, 5)))
    if setting == "among":
        return among_rig(scene, rng)
    raise ValueError(f"unknown setting {setting!r}; expected one of {SETTINGS}")
