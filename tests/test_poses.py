"""Pose tools: semantics of left/right/forward, and algebraic properties under random poses."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shared.geometry.poses import (
    as_4x4,
    camera_center,
    estimate_up_axis,
    move_backward,
    move_forward,
    rotate_left,
    rotate_right,
    turn_around,
    validate_extrinsic,
)

WORLD_UP = np.array([0.0, 0.0, 1.0])


def look_pose(center: np.ndarray, yaw_deg: float, pitch_deg: float = 0.0) -> np.ndarray:
    """A 3x4 pose in a z-up world: yaw 0 looks along +x, positive yaw turns toward +y (left)."""
    yaw, pitch = np.radians(yaw_deg), np.radians(pitch_deg)
    forward = np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    right = np.cross(forward, WORLD_UP)
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    rotation = np.stack([right, down, forward])
    return np.hstack([rotation, (-rotation @ center)[:, None]])


def project_x(extrinsic: np.ndarray, point: np.ndarray) -> tuple[float, float]:
    """Camera-frame (x, z) of a world point."""
    camera = extrinsic[:3, :3] @ point + extrinsic[:3, 3]
    return float(camera[0]), float(camera[2])


unit = st.floats(-1.0, 1.0, allow_nan=False)
coordinate = st.floats(-10.0, 10.0, allow_nan=False)
angle = st.floats(-179.0, 179.0, allow_nan=False)


@st.composite
def poses(draw: st.DrawFn) -> np.ndarray:
    quaternion = np.array([draw(unit) for _ in range(4)])
    if np.linalg.norm(quaternion) < 0.1:
        quaternion = np.array([1.0, 0.0, 0.0, 0.0])
    w, x, y, z = quaternion / np.linalg.norm(quaternion)
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    translation = np.array([draw(coordinate) for _ in range(3)])
    return np.hstack([rotation, translation[:, None]])


def test_left_brings_the_left_of_the_image_to_the_centre() -> None:
    pose = look_pose(np.array([1.0, 2.0, 1.5]), yaw_deg=30.0)
    # A point 45 degrees to the camera's left (camera -x) at distance 2.
    target = camera_center(pose) + 2.0 * np.array([np.cos(np.radians(75.0)), np.sin(np.radians(75.0)), 0])
    x_before, _ = project_x(pose, target)
    assert x_before < 0  # really on the left of the image
    x_after, z_after = project_x(rotate_left(pose, 45.0, up=WORLD_UP), target)
    assert abs(x_after) < 1e-9 and z_after > 0
    x_right, _ = project_x(rotate_right(pose, 45.0, up=WORLD_UP), target)
    assert x_right < x_before  # turning right pushes it further left


def test_default_up_is_the_cameras_own_image_up() -> None:
    pose = look_pose(np.zeros(3), yaw_deg=0.0)  # level camera: image up == world up
    np.testing.assert_allclose(rotate_left(pose), rotate_left(pose, up=WORLD_UP), atol=1e-12)
    np.testing.assert_allclose(move_forward(pose), move_forward(pose, up=WORLD_UP), atol=1e-12)


def test_tilted_camera_keeps_horizon_with_scene_up() -> None:
    pose = look_pose(np.array([0.0, 0.0, 1.0]), yaw_deg=0.0, pitch_deg=-30.0)  # looking down
    turned = rotate_left(pose, 90.0, up=WORLD_UP)
    forward = turned[2, :3]
    np.testing.assert_allclose(forward, [0.0, np.cos(np.radians(30)), -np.sin(np.radians(30))], atol=1e-12)
    moved = move_forward(pose, 0.5, up=WORLD_UP)
    np.testing.assert_allclose(camera_center(moved), [0.5, 0.0, 1.0], atol=1e-12)


def test_camera_looking_straight_down_moves_toward_the_top_of_its_image() -> None:
    down = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # image top = +x
    pose = np.hstack([down, np.zeros((3, 1))])
    assert np.isclose(np.linalg.det(down), 1.0)
    np.testing.assert_allclose(camera_center(move_forward(pose, 1.0, up=WORLD_UP)), [1.0, 0, 0], atol=1e-12)


def test_estimate_up_axis_averages_image_ups() -> None:
    # Opposite cameras pitched down alike: their tilts cancel and the mean is the world up.
    cameras = np.stack([look_pose(np.zeros(3), yaw_deg=a, pitch_deg=-20.0) for a in (0.0, 180.0)])
    np.testing.assert_allclose(estimate_up_axis(cameras), WORLD_UP, atol=1e-12)
    single = estimate_up_axis(cameras[0])
    np.testing.assert_allclose(single, -cameras[0, 1, :3], atol=1e-12)


def test_estimate_up_axis_falls_back_when_cameras_cancel() -> None:
    pose = look_pose(np.zeros(3), yaw_deg=0.0)
    flipped = pose.copy()
    flipped[1] *= -1  # upside down: roll by 180 degrees about the optical axis
    flipped[0] *= -1
    np.testing.assert_allclose(estimate_up_axis(np.stack([pose, flipped])), -pose[1, :3], atol=1e-12)


@pytest.mark.parametrize(
    ("matrix", "message"),
    [
        (np.zeros((3, 3)), "3x4 or 4x4"),
        (np.full((3, 4), np.nan), "non-finite"),
        (np.hstack([2 * np.eye(3), np.zeros((3, 1))]), "orthonormal"),
        (np.hstack([-np.eye(3), np.zeros((3, 1))]), "reflection"),
        (np.vstack([np.hstack([np.eye(3), np.zeros((3, 1))]), [[0, 0, 1, 1]]]), "0, 0, 0, 1"),
    ],
)
def test_validation_rejects_bad_extrinsics(matrix: np.ndarray, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        validate_extrinsic(matrix)
    with pytest.raises(ValueError, match=message):
        rotate_left(matrix)


def test_validation_rejects_bad_up() -> None:
    pose = look_pose(np.zeros(3), 0.0)
    with pytest.raises(ValueError, match="zero vector"):
        rotate_left(pose, up=np.zeros(3))
    with pytest.raises(ValueError, match="3 finite"):
        move_forward(pose, up=np.array([0.0, np.inf, 1.0]))


@settings(max_examples=60, deadline=None)
@given(poses(), angle)
def test_left_then_right_is_identity(pose: np.ndarray, degrees: float) -> None:
    np.testing.assert_allclose(rotate_right(rotate_left(pose, degrees), degrees), pose, atol=1e-9)
    up = estimate_up_axis(pose)
    np.testing.assert_allclose(rotate_left(rotate_right(pose, degrees, up), degrees, up), pose, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(poses())
def test_four_quarter_turns_and_two_half_turns_are_identity(pose: np.ndarray) -> None:
    turned = pose
    for _ in range(4):
        turned = rotate_left(turned, 90.0, up=WORLD_UP)
    np.testing.assert_allclose(turned, pose, atol=1e-9)
    np.testing.assert_allclose(turn_around(turn_around(pose, WORLD_UP), WORLD_UP), pose, atol=1e-9)
    np.testing.assert_allclose(turn_around(turn_around(pose)), pose, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(poses(), angle)
def test_rotation_keeps_the_centre(pose: np.ndarray, degrees: float) -> None:
    for turned in (rotate_left(pose, degrees, WORLD_UP), rotate_right(pose, degrees), turn_around(pose)):
        np.testing.assert_allclose(camera_center(turned), camera_center(pose), atol=1e-9)
        validate_extrinsic(turned)


@settings(max_examples=60, deadline=None)
@given(poses(), st.floats(-5.0, 5.0, allow_nan=False))
def test_moving_keeps_height_and_orientation(pose: np.ndarray, distance: float) -> None:
    moved = move_forward(pose, distance, up=WORLD_UP)
    np.testing.assert_allclose(moved[:3, :3], pose[:3, :3], atol=1e-12)
    step = camera_center(moved) - camera_center(pose)
    assert abs(step @ WORLD_UP) < 1e-9
    assert np.isclose(np.linalg.norm(step), abs(distance), atol=1e-9)
    np.testing.assert_allclose(move_backward(moved, distance, up=WORLD_UP), pose, atol=1e-9)
    np.testing.assert_allclose(move_backward(move_forward(pose, distance), distance), pose, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(poses(), angle)
def test_4x4_in_gives_4x4_out(pose: np.ndarray, degrees: float) -> None:
    square = as_4x4(pose)
    for tool in (rotate_left, rotate_right, move_forward, move_backward):
        result = tool(square, degrees / 10.0)
        assert result.shape == (4, 4)
        np.testing.assert_allclose(result[3], [0, 0, 0, 1])
        np.testing.assert_allclose(result[:3], tool(pose, degrees / 10.0), atol=1e-12)
    assert turn_around(square).shape == (4, 4)
    assert rotate_left(pose).shape == (3, 4)


def test_up_axis_is_exact_for_cameras_pitched_down_at_a_subject():
    # Cameras on an arc, 1 m above a subject they look down at (z-up world): the mean of their -y
    # axes tilts towards the subject; the x axes stay horizontal and give up exactly.
    from shared.synthetic import look_at

    subject = np.array([0.0, 0.0, 0.5])
    poses = []
    for angle in np.radians([-90.0, -70.0, -50.0]):
        eye = subject + np.array([2.0 * np.cos(angle), 2.0 * np.sin(angle), 1.0])
        poses.append(look_at(eye, subject))
    poses = np.stack(poses)
    naive = -poses[:, 1, :3].mean(axis=0)
    assert naive[2] / np.linalg.norm(naive) < 0.95  # the old estimate was off by > 18 degrees
    np.testing.assert_allclose(estimate_up_axis(poses), [0.0, 0.0, 1.0], atol=1e-9)
    # Same heading (x axes parallel): no plane to fit, the -y mean is the answer.
    sideways = np.stack([look_at([x, -2.0, 1.5], [x, 0.0, 0.5]) for x in (0.0, 0.5)])
    assert estimate_up_axis(sideways) @ [0.0, 0.0, 1.0] > 0.85
