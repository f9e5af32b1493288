"""Camera motion descriptions for cameras whose motion is known by construction."""

from __future__ import annotations

import json

import numpy as np
import pytest

from shared.geometry.camera_motion import (
    DIRECTIONS,
    NO_MOVEMENT,
    NO_ROTATION,
    default_pairs,
    describe_camera_motion,
    describe_pairs,
    direction_name,
    robust_extent,
    round_turn,
)
from shared.geometry.poses import as_4x4, move_forward, rotate_left, rotate_right

WORLD_UP = np.array([0.0, 0.0, 1.0])


def level_pose(center: np.ndarray, heading_deg: float) -> np.ndarray:
    """A level camera in a z-up world; heading 0 looks along +x, positive headings turn left."""
    heading = np.radians(heading_deg)
    forward = np.array([np.cos(heading), np.sin(heading), 0.0])
    right = np.cross(forward, WORLD_UP)
    rotation = np.stack([right, np.cross(forward, right), forward])
    return np.hstack([rotation, (-rotation @ center)[:, None]])


def step(heading_deg: float, move_deg: float, distance: float = 1.0) -> np.ndarray:
    """Two views: the second camera stands `distance` away at `move_deg` (0 fwd, +90 right)."""
    first = level_pose(np.array([2.0, -1.0, 1.5]), heading_deg)
    ahead = np.radians(heading_deg - move_deg)  # a move to the right lowers the world heading
    second_center = np.array([2.0, -1.0, 1.5]) + distance * np.array([np.cos(ahead), np.sin(ahead), 0.0])
    return np.stack([first, level_pose(second_center, heading_deg)])


@pytest.mark.parametrize(("move_deg", "expected"), list(zip(range(0, 360, 45), DIRECTIONS, strict=True)))
def test_all_eight_directions(move_deg: int, expected: str) -> None:
    for heading in (0.0, 37.0, -120.0):
        [motion] = describe_camera_motion(step(heading, move_deg + 10.0), up=WORLD_UP)
        assert motion.direction == expected
        assert motion.turn == NO_ROTATION
        assert motion.distance == pytest.approx(1.0)
        assert motion.angle_deg % 360 == pytest.approx((move_deg + 10.0) % 360)
        assert f"moved {expected} without turning" in motion.sentence


def test_displacement_is_in_the_first_cameras_frame() -> None:
    [motion] = describe_camera_motion(step(60.0, -90.0, distance=2.0))  # up estimated from cameras
    assert motion.direction == "left"
    np.testing.assert_allclose(motion.displacement_in_first_camera, [-2.0, 0.0, 0.0], atol=1e-12)


def test_sector_bounds_are_22_5_degrees() -> None:
    assert direction_name(22.4) == "forward" and direction_name(-22.4) == "forward"
    assert direction_name(22.6) == "diagonally forward and right"
    assert direction_name(-22.6) == "diagonally forward and left"
    assert direction_name(180.0) == "backward" and direction_name(-170.0) == "backward"


def test_no_movement_below_threshold_of_scene_scale() -> None:
    cameras = step(0.0, 0.0, distance=0.04)
    [small] = describe_camera_motion(cameras, scene_scale=1.0)
    assert small.direction == NO_MOVEMENT
    assert small.still and small.sentence == (
        "From view 1 to view 2, in view 1's image axes, the camera stayed still: no step of 0.05 scene units "
        "or more, no turn of 10 degrees or more, no tilt or roll of 5 degrees or more."
    )
    [same] = describe_camera_motion(cameras, scene_scale=0.5)
    assert same.direction == "forward"


def test_default_scale_comes_from_camera_centres() -> None:
    far = level_pose(np.array([10.0, 0.0, 0.0]), 0.0)
    near = step(0.0, 0.0, distance=0.1)  # 0.1 against an extent of ~10: not significant
    motions = describe_camera_motion(np.stack([near[0], near[1], far]))
    assert motions[0].direction == NO_MOVEMENT
    assert motions[1].direction == "forward"
    assert robust_extent(np.stack([np.zeros(3), np.ones(3)])) == pytest.approx(np.sqrt(3.0))


def test_all_centres_coincide_uses_unit_scale() -> None:
    first = level_pose(np.zeros(3), 0.0)
    motions = describe_camera_motion(np.stack([first, rotate_left(first, 90.0), rotate_right(first, 45.0)]))
    assert [m.direction for m in motions] == [NO_MOVEMENT, NO_MOVEMENT]
    assert motions[0].turn == "turned left by about 90 degrees"
    assert motions[0].yaw_deg == pytest.approx(90.0)
    assert motions[1].turn == "turned right by about 135 degrees"
    assert motions[0].sentence == (
        "From view 1 to view 2, in view 1's image axes, "
        "the camera stayed in place and turned left by about 90 degrees."
    )


@pytest.mark.parametrize(
    ("yaw", "expected"),
    [
        (8.0, NO_ROTATION),
        (-12.0, "turned right by about 10 degrees"),
        (23.0, "turned left by about 25 degrees"),
        (43.0, "turned left by about 45 degrees"),
        (-88.0, "turned right by about 90 degrees"),
        (178.0, "turned around by about 180 degrees"),
    ],
)
def test_pure_rotations(yaw: float, expected: str) -> None:
    first = level_pose(np.array([0.0, 1.0, 1.0]), 20.0)
    second = rotate_left(first, yaw, up=WORLD_UP)
    [motion] = describe_camera_motion(np.stack([first, second]), up=WORLD_UP)
    assert motion.direction == NO_MOVEMENT and motion.turn == expected
    assert motion.yaw_deg == pytest.approx(yaw)


def test_combined_move_and_turn_with_a_tilted_camera() -> None:
    pitch_down = np.radians(-25.0)
    tilt = np.array(
        [[1, 0, 0], [0, np.cos(pitch_down), -np.sin(pitch_down)], [0, np.sin(pitch_down), np.cos(pitch_down)]]
    )
    first = level_pose(np.array([0.0, 0.0, 1.6]), 0.0)
    first[:, :3] = tilt @ first[:, :3]
    first[:, 3] = -first[:, :3] @ np.array([0.0, 0.0, 1.6])
    moved = move_forward(rotate_left(first, 45.0, up=WORLD_UP), 1.0, up=WORLD_UP)
    second = rotate_left(moved, 45.0, up=WORLD_UP)
    [motion] = describe_camera_motion(np.stack([as_4x4(first), as_4x4(second)]), up=WORLD_UP)
    assert motion.direction == "diagonally forward and left"
    assert motion.angle_deg == pytest.approx(-45.0)
    assert motion.vertical == pytest.approx(0.0, abs=1e-12)
    assert motion.yaw_deg == pytest.approx(90.0)
    # Pitched down, a turn about gravity is a turn, a tilt and a roll in the photo's axes: both are said.
    assert motion.frames_differ and motion.gravity is not None
    assert (
        motion.gravity.phrase == "moved diagonally forward and left and turned left by about 90 degrees "
        "(a step of 1.00 scene units)"
    )
    assert "; in the scene's gravity frame it " + motion.gravity.phrase + ";" in motion.sentence
    # After the turn the step is stated again in view 2's own axes (the last clause).
    assert motion.sentence.split("; ")[-1].startswith("in view 2's image axes it moved ")
    payload = json.loads(json.dumps(motion.to_dict()))
    assert payload["from_view"] == 0 and payload["to_view"] == 1
    assert len(payload["displacement_in_first_camera"]) == 3


def test_custom_pairs_and_validation() -> None:
    cameras = np.concatenate([step(0.0, 90.0), step(0.0, 180.0)[1:]])
    [motion] = describe_camera_motion(cameras, pairs=[(1, 2)], up=WORLD_UP)
    assert motion.from_view == 1 and motion.direction == "diagonally back and left"
    assert motion.sentence.startswith("From view 2 to view 3")
    with pytest.raises(ValueError, match="out of range"):
        describe_camera_motion(cameras, pairs=[(0, 3)])
    with pytest.raises(ValueError, match="shape"):
        describe_camera_motion(cameras[0])
    with pytest.raises(ValueError, match="scene_scale"):
        describe_camera_motion(cameras, scene_scale=0.0)


def test_round_turn_steps() -> None:
    assert [round_turn(a) for a in (12, 17, 28, 31, 52, 98, -134)] == [10, 15, 30, 30, 45, 105, 135]


def lifted(cameras: np.ndarray, rise: float) -> np.ndarray:
    """The same cameras with the second one `rise` higher (z-up world)."""
    second = cameras[1].copy()
    second[:, 3] = second[:, 3] - second[:, :3] @ np.array([0.0, 0.0, rise])
    return np.stack([cameras[0], second])


@pytest.mark.parametrize(
    ("move_distance", "rise", "direction", "vertical", "words"),
    [
        (1.0, 0.2, "forward", None, "moved forward without turning"),  # 11 degrees up: level enough
        (1.0, 0.6, "forward", "up", "moved forward and up without turning"),  # 31 degrees
        (1.0, -0.6, "forward", "down", "moved forward and down without turning"),
        (0.0, 0.8, NO_MOVEMENT, "up", "moved up without turning"),
        (0.2, 1.0, NO_MOVEMENT, "up", "moved up without turning"),  # 79 degrees: only vertical
        (0.0, 0.03, NO_MOVEMENT, None, "stayed still"),  # below the threshold
    ],
)
def test_vertical_motion_is_said_when_significant(move_distance, rise, direction, vertical, words) -> None:
    cameras = lifted(step(30.0, 0.0, distance=move_distance), rise)
    [motion] = describe_camera_motion(cameras, up=WORLD_UP, scene_scale=1.0)
    assert motion.direction == direction and motion.vertical_direction == vertical
    assert motion.vertical == pytest.approx(rise)
    assert words in motion.sentence


def test_vertical_motion_with_a_turn() -> None:
    first, second = lifted(step(0.0, -90.0), 0.7)
    [motion] = describe_camera_motion(np.stack([first, rotate_left(second, 60.0, up=WORLD_UP)]), up=WORLD_UP)
    assert motion.sentence == (
        "From view 1 to view 2, in view 1's image axes, "
        "the camera moved left and up, and turned left by about 60 degrees "
        "(a step of 1.22 scene units); in view 2's image axes it moved diagonally forward and left and up."
    )  # left of view 1 is 30 degrees left of forward once the camera turned left by 60


def test_scene_scale_from_points_keeps_a_pure_turn_a_turn() -> None:
    """Two views: a 90-degree turn with 1 cm of drift. The centres alone make the drift the scene."""
    first = level_pose(np.array([0.0, 0.0, 1.5]), 0.0)
    drifted = first.copy()
    drifted[:, 3] -= drifted[:, :3] @ np.array([0.01, -0.004, 0.0])
    second = rotate_left(drifted, 90.0, up=WORLD_UP)
    cameras = np.stack([first, second])
    [by_centres] = describe_camera_motion(cameras, up=WORLD_UP)
    assert by_centres.direction != NO_MOVEMENT  # the old behaviour: "moved right and turned left"
    room = np.random.default_rng(0).uniform([-3, -3, 0], [3, 3, 2.5], size=(2000, 3))
    [by_points] = describe_camera_motion(cameras, up=WORLD_UP, scene_scale=robust_extent(room))
    assert by_points.sentence == (
        "From view 1 to view 2, in view 1's image axes, "
        "the camera stayed in place and turned left by about 90 degrees."
    )


def test_pairs_with_an_unusable_view_say_why_and_the_rest_are_described() -> None:
    cameras = np.concatenate([step(0.0, 90.0), step(0.0, 180.0)[1:], step(0.0, 0.0)[1:]])
    cameras[2] = np.nan  # view 3 (index 2) has no pose
    problems = [None, None, "view 3 could not be registered by the classical backbone", None]
    assert default_pairs(4, [p is None for p in problems]) == [(0, 1), (1, 2), (1, 3), (2, 3)]
    motions = describe_pairs(cameras, problems, up=WORLD_UP)
    assert [m.described for m in motions] == [True, False, True, False]
    assert motions[0].sentence.startswith(
        "From view 1 to view 2, in view 1's image axes, the camera moved right"
    )
    assert motions[1].reason == problems[2]
    assert motions[1].sentence == (
        "From view 2 to view 3 the camera motion is unknown: view 3 could not be registered by the "
        "classical backbone."
    )
    assert motions[2].from_view == 1 and motions[2].to_view == 3  # the bridge over the gap
    assert motions[2].sentence.startswith("From view 2 to view 4, in view 2's image axes, the camera moved")
    [only] = describe_pairs(cameras, problems, pairs=[(2, 2)])
    assert not only.described and only.reason == problems[2]
    everything_unknown = describe_pairs(cameras, ["a", "b", "c", "d"])
    assert [m.reason for m in everything_unknown] == ["a; b", "b; c", "c; d"]
    assert json.loads(json.dumps(motions[1].to_dict()))["described"] is False


def test_view_problems_and_scale_of_a_reconstruction() -> None:
    from services.recon.motion_inputs import motion_scene_scale, view_pose_problems
    from shared.geometry.reconstruction import Reconstruction

    cameras = np.concatenate([step(0.0, 90.0), step(0.0, 180.0)[1:], step(0.0, 0.0)[1:]])
    cameras[2, :, :3] *= 1.5  # "registered", but not a rotation
    cameras[3] = np.nan
    room = np.random.default_rng(1).uniform(-2.0, 2.0, size=(500, 3))
    recon = Reconstruction(
        points=room,
        colors=np.zeros((500, 3)),
        extrinsics=cameras,
        intrinsics=np.tile(np.eye(3), (4, 1, 1)),
        image_sizes=np.full((4, 2), 64),
        registered=[True, True, True, False],
        backbone="classical",
        backbone_version="2",
    )
    problems = view_pose_problems(recon)
    assert problems[:2] == [None, None]
    assert problems[2].startswith("view 3 has no valid pose (rotation block is not orthonormal")
    assert problems[3] == "view 4 could not be registered by the classical backbone"
    assert motion_scene_scale(recon, [0, 1]) == pytest.approx(robust_extent(room))
    recon.points = np.zeros((0, 3), np.float32)
    recon.colors = np.zeros((0, 3), np.uint8)
    assert motion_scene_scale(recon, [0, 1]) == pytest.approx(1.0)  # two centres 1 apart: their extent
    assert motion_scene_scale(recon, [0]) == 1.0  # one centre: no extent at all


def test_metric_scenes_say_how_far_and_relative_ones_only_which_way():
    from shared.geometry.camera_motion import describe_pairs

    first = np.hstack([np.eye(3), np.zeros((3, 1))])
    second = np.hstack([np.eye(3), np.array([[-0.1], [0.25], [-0.42]])])  # forward 0.42, right 0.1, up 0.25
    metric = describe_camera_motion(np.stack([first, second]), scene_scale=1.0, units="metres")[0]
    assert metric.units == "metres" and metric.distance == pytest.approx(np.hypot(0.42, 0.1))
    assert metric.sentence == (
        "From view 1 to view 2, in view 1's image axes, "
        "the camera moved 0.43 m forward and 0.25 m up without turning significantly."
    )
    relative = describe_camera_motion(np.stack([first, second]), scene_scale=1.0)[0]
    assert relative.units == "relative"
    assert (
        relative.sentence == "From view 1 to view 2, in view 1's image axes, "
        "the camera moved forward and up without turning significantly "
        "(a step of 0.50 scene units)."
    )
    [pair] = describe_pairs(np.stack([first, second]), [None, None], scene_scale=1.0, units="metres")
    assert pair.sentence == metric.sentence and pair.to_dict()["units"] == "metres"
    with pytest.raises(ValueError, match="units"):
        describe_camera_motion(np.stack([first, second]), units="feet")
