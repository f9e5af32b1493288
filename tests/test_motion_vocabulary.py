"""Every word of the camera-motion vocabulary, on cameras whose motion is known by construction.

The cameras are built in the first camera's own axes (x right, y down, z forward), so each word's
expected value is exact: a step along one axis, a rotation about one axis.
"""

from __future__ import annotations

import numpy as np
import pytest

from shared.geometry.camera_motion import describe_camera_motion
from shared.geometry.poses import up_is_reliable

WORLD_UP = np.array([0.0, 0.0, 1.0])


def _axis_rotation(axis: str, degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def level_rotation(heading_deg: float = 20.0, roll_deg: float = 0.0) -> np.ndarray:
    """Camera-from-world rotation of a level camera in a z-up world, rolled by `roll_deg` (+ = clockwise)."""
    heading = np.radians(heading_deg)
    forward = np.array([np.cos(heading), np.sin(heading), 0.0])
    right = np.cross(forward, WORLD_UP)
    level = np.stack([right, np.cross(forward, right), forward])
    # A roll about the viewing direction by +a sends the camera's right side down (clockwise from behind).
    return _axis_rotation("z", -roll_deg) @ level


def pair(step_in_camera=(0.0, 0.0, 0.0), rotation_in_camera=np.eye(3), first_rotation=None) -> np.ndarray:
    """Two poses: camera 2's centre is camera 1's plus `step_in_camera` (x right, y down, z forward),
    and its axes (columns) are those of `rotation_in_camera`, in camera 1's coordinates."""
    rotation = level_rotation() if first_rotation is None else first_rotation
    center = np.array([1.0, -2.0, 1.5])
    second_rotation = rotation_in_camera.T @ rotation
    second_center = center + rotation.T @ np.asarray(step_in_camera, dtype=float)
    poses = [
        np.hstack([r, (-r @ c)[:, None]]) for r, c in ((rotation, center), (second_rotation, second_center))
    ]
    return np.stack(poses)


def describe(cameras: np.ndarray, **options):
    return describe_camera_motion(cameras, up=WORLD_UP, scene_scale=1.0, **options)[0]


@pytest.mark.parametrize(
    ("step", "words"),
    [
        ((0.3, 0.0, 0.0), "moved right"),
        ((-0.3, 0.0, 0.0), "moved left"),
        ((0.0, -0.3, 0.0), "moved up"),
        ((0.0, 0.3, 0.0), "moved down"),
        ((0.0, 0.0, 0.3), "moved forward"),
        ((0.0, 0.0, -0.3), "moved backward"),
        ((0.3, 0.0, 0.3), "moved diagonally forward and right"),
        ((-0.3, 0.0, -0.3), "moved diagonally back and left"),
        ((0.3, 0.3, 0.0), "moved right and down"),
    ],
)
def test_each_step_is_named_with_its_size(step, words) -> None:
    motion = describe(pair(step_in_camera=step))
    size = np.linalg.norm(step)
    assert motion.image is not None
    assert motion.image.phrase == f"{words} without turning significantly (a step of {size:.2f} scene units)"
    assert (motion.image.right, motion.image.up, motion.image.forward) == pytest.approx(
        (step[0], -step[1], step[2])
    )
    assert not motion.frames_differ and not motion.still  # a level camera: gravity says the same
    metric = describe(pair(step_in_camera=step), units="metres")
    assert (
        f"{abs(step[1]) or size:.2f} m" in metric.sentence
        or f"{np.hypot(step[0], step[2]):.2f} m" in metric.sentence
    )


@pytest.mark.parametrize(
    ("axis", "degrees", "words", "angles"),
    [
        ("y", -30.0, "turned left by about 30 degrees", (30.0, 0.0, 0.0)),
        ("y", 45.0, "turned right by about 45 degrees", (-45.0, 0.0, 0.0)),
        ("x", 8.0, "tilted up by about 8 degrees", (0.0, 8.0, 0.0)),
        ("x", -20.0, "tilted down by about 20 degrees", (0.0, -20.0, 0.0)),
        ("z", 15.0, "rolled clockwise by about 15 degrees", (0.0, 0.0, 15.0)),
        ("z", -60.0, "rolled counterclockwise by about 60 degrees", (0.0, 0.0, -60.0)),
    ],
)
def test_each_rotation_is_named_with_its_angle(axis, degrees, words, angles) -> None:
    # Camera 2's axes are camera 1's turned by the rotation: about +x by +8 degrees lifts the view: tilted up.
    motion = describe(pair(rotation_in_camera=_axis_rotation(axis, degrees)))
    assert motion.image.phrase == f"stayed in place and {words}"
    assert (motion.image.turn_deg, motion.image.tilt_deg, motion.image.roll_deg) == pytest.approx(
        angles, abs=1e-9
    )
    assert not motion.frames_differ  # level first camera: the gravity frame agrees


def test_a_step_with_a_tilt_and_a_turn_says_all_three() -> None:
    rotation = _axis_rotation("x", 12.0) @ _axis_rotation("y", -20.0)
    motion = describe(pair(step_in_camera=(0.0, 0.2, 0.0), rotation_in_camera=rotation))
    assert motion.image.phrase.startswith(
        "moved down, and turned left by about 20 degrees and tilted up by about"
    )


def test_still_below_the_stated_thresholds_and_not_above() -> None:
    below = describe(pair(step_in_camera=(0.04, 0.0, 0.0), rotation_in_camera=_axis_rotation("x", 4.0)))
    assert below.still and "stayed still: no step of 0.05 scene units or more" in below.sentence
    assert below.thresholds == {
        "distance": 0.05,
        "distance_fraction_of_scene": 0.05,
        "scene_scale": 1.0,
        "turn_deg": 10.0,
        "tilt_deg": 5.0,
        "roll_deg": 5.0,
    }
    identical = describe(pair())
    assert identical.still
    tilted = describe(pair(rotation_in_camera=_axis_rotation("x", -6.0)))
    assert not tilted.still and "tilted down by about 6 degrees" in tilted.sentence


def test_closer_to_and_farther_from_a_target() -> None:
    cameras = pair(step_in_camera=(0.0, 0.0, 0.5))
    ahead = -cameras[0, :, :3].T @ cameras[0, :, 3] + 2.0 * cameras[0, 2, :3]  # 2 units in front of camera 1
    closer = describe(cameras, target=ahead, target_name="the object at pixel (320, 240) of view 1")
    assert closer.target_change == "closer" and closer.target_distances == pytest.approx((2.0, 1.5))
    assert closer.sentence.endswith(
        "; it came closer to the object at pixel (320, 240) of view 1 (2.00 scene units to 1.50 scene units)."
    )
    back = describe(pair(step_in_camera=(0.0, 0.0, -0.5)), target=ahead)
    assert back.target_change == "farther" and "moved farther from the target" in back.sentence
    aside = describe(pair(step_in_camera=(0.01, 0.0, 0.0)), target=ahead)
    assert aside.target_change == "same distance"


def test_rolled_photos_state_both_frames() -> None:
    # Both photos held sideways (rolled 90 degrees clockwise); the camera rose 0.3 along gravity.
    sideways = level_rotation(roll_deg=90.0)
    center = np.array([0.0, 0.0, 1.0])
    first = np.hstack([sideways, (-sideways @ center)[:, None]])
    second = np.hstack([sideways, (-sideways @ (center + 0.3 * WORLD_UP))[:, None]])
    motion = describe(np.stack([first, second]))
    # Rolled clockwise, the camera's left side points up: in the photo the step is to the left.
    assert motion.image.phrase.startswith("moved left without turning")
    assert motion.gravity is not None and motion.gravity.phrase.startswith("moved up without turning")
    assert motion.frames_differ
    assert "; in the scene's gravity frame it moved up" in motion.sentence
    assert motion.vertical_direction == "up" and motion.direction == "no significant movement"


def test_a_roll_against_gravity_is_the_same_roll_in_both_frames() -> None:
    motion = describe(pair(rotation_in_camera=_axis_rotation("z", 25.0)))
    assert motion.gravity.roll_deg == pytest.approx(25.0) and motion.image.roll_deg == pytest.approx(25.0)


def test_gravity_frame_only_when_up_is_reliable() -> None:
    headings = [level_rotation(heading_deg=h) for h in (0.0, 60.0, 120.0)]
    spread = np.stack([np.hstack([r, np.zeros((3, 1))]) for r in headings])
    assert up_is_reliable(spread)
    alike = pair(step_in_camera=(0.3, 0.0, 0.0))
    assert not up_is_reliable(alike)  # one heading: up is only the photos' own up
    motion = describe_camera_motion(alike, scene_scale=1.0)[0]
    assert motion.gravity is None and not motion.frames_differ
    given = describe_camera_motion(alike, up=WORLD_UP, scene_scale=1.0)[0]
    assert given.gravity is not None
