"""The classical backbone on rendered scenes with exact cameras, plus its two-view core on
synthetic correspondences. Everything here is real OpenCV on real pixels; nothing is mocked."""

from __future__ import annotations

import numpy as np
import pytest

from services.recon.backbones.base import BackboneError, create_backbone
from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.features import detect_features, match_features
from services.recon.backbones.classical.intrinsics import (
    guess_intrinsics,
    intrinsics_after_resize,
    intrinsics_before_resize,
)
from services.recon.backbones.classical.two_view import estimate_two_view
from shared.geometry.reconstruction import Reconstruction
from shared.synthetic import among_rig, default_intrinsic, generate_scene, look_at, render_view

WIDTH, HEIGHT = 480, 360
K = default_intrinsic(WIDTH, HEIGHT, 60.0)
SCENE_SEED = 11
AMONG_SEED = 500  # a scene with room for the among rig, outside the benchmark's seeds


def relative_pose(first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    rotation = second[:, :3] @ first[:, :3].T
    return rotation, second[:, 3] - rotation @ first[:, 3]


def rotation_error_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(a @ b.T) - 1) / 2, -1, 1))))


def direction_error_deg(a: np.ndarray, b: np.ndarray) -> float:
    cosine = np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(cosine, -1, 1))))


def arc_cameras(scene, count: int = 4, step_deg: float = 15.0) -> list[np.ndarray]:
    """Walk an arc around the room centre, looking at a point above the floor there."""
    target = scene.room_centre.copy()
    target[2] = 0.6
    cameras = []
    for index in range(count):
        angle = np.radians(-90.0 + step_deg * index)
        eye = target + 1.9 * np.array([np.cos(angle), np.sin(angle), 0.0])
        eye[2] = 1.45
        cameras.append(look_at(eye, target))
    return cameras


def turning_cameras(scene, count: int = 4, step_deg: float = 35.0) -> list[np.ndarray]:
    """Stand at the room centre and turn left by `step_deg` per view, looking a little down."""
    eye = np.array([*scene.room_centre[:2], 1.5])
    cameras = []
    for index in range(count):
        yaw = np.radians(20.0 + step_deg * index)
        cameras.append(look_at(eye, eye + np.array([np.cos(yaw), np.sin(yaw), -0.2])))
    return cameras


@pytest.fixture(scope="module")
def scene():
    return generate_scene(SCENE_SEED)


@pytest.fixture(scope="module")
def arc(scene):
    cameras = arc_cameras(scene)
    return cameras, [render_view(scene, camera, K, WIDTH, HEIGHT).rgb for camera in cameras]


@pytest.fixture(scope="module")
def arc_result(arc) -> Reconstruction:
    return ClassicalBackbone().reconstruct(arc[1])


def test_walking_around_gives_accurate_relative_poses(arc, arc_result):
    cameras, _ = arc
    assert arc_result.registered.all(), arc_result.warnings
    for index in range(len(cameras) - 1):
        true_rotation, true_translation = relative_pose(cameras[index], cameras[index + 1])
        rotation, translation = relative_pose(arc_result.extrinsics[index], arc_result.extrinsics[index + 1])
        assert rotation_error_deg(rotation, true_rotation) < 5.0
        assert direction_error_deg(translation, true_translation) < 15.0


def test_world_is_the_first_camera_and_scale_is_unit_median_distance(arc_result):
    np.testing.assert_allclose(arc_result.extrinsics[0], np.hstack([np.eye(3), np.zeros((3, 1))]), atol=1e-12)
    distances = np.linalg.norm(arc_result.points.astype(np.float64), axis=1)
    assert np.median(distances) == pytest.approx(1.0, rel=1e-4)
    # The cameras' shape is right too: ratios of the true baselines survive the unknown scale.
    centres = arc_result.camera_centers()
    baselines = np.linalg.norm(np.diff(centres, axis=0), axis=1)
    np.testing.assert_allclose(baselines / baselines[0], np.ones(3), rtol=0.1)


def test_output_types_shapes_and_reported_intrinsics(arc_result):
    result = arc_result
    assert (result.backbone, result.backbone_version) == ("classical", "6")
    assert result.points.dtype == np.float32 and result.points.shape[1] == 3
    assert result.colors.dtype == np.uint8 and len(result.colors) == len(result.points)
    assert result.extrinsics.shape == (4, 3, 4) and np.isfinite(result.extrinsics).all()
    assert result.image_sizes.tolist() == [[WIDTH, HEIGHT]] * 4
    # The renders are 60 degree cameras, the prior: a self-calibrated focal must agree with it.
    assert len(set(result.intrinsics_source)) == 1
    assert result.intrinsics_source[0] in ("prior", "self-calibrated")
    np.testing.assert_allclose(
        result.intrinsics,
        np.broadcast_to(guess_intrinsics(WIDTH, HEIGHT, 60.0), (4, 3, 3)),
        rtol=0 if result.intrinsics_source[0] == "prior" else 0.03,
    )
    assert result.depths is not None and len(result.depths) == 4
    assert all(depth.dtype == np.float32 and (depth > 0).mean() > 0.2 for depth in result.depths)


def test_cloud_colours_come_from_the_images(arc, arc_result):
    _, images = arc
    extrinsic, intrinsic = arc_result.extrinsics[0], arc_result.intrinsics[0]
    camera = arc_result.points.astype(np.float64) @ extrinsic[:, :3].T + extrinsic[:, 3]
    pixels = camera[:, :2] / camera[:, 2:] * intrinsic[[0, 1], [0, 1]] + intrinsic[:2, 2]
    u, v = np.round(pixels).astype(int).T
    inside = (camera[:, 2] > 0) & (u >= 0) & (v >= 0) & (u < WIDTH) & (v < HEIGHT)
    assert inside.sum() > 1000
    difference = np.abs(images[0][v[inside], u[inside]].astype(int) - arc_result.colors[inside].astype(int))
    # Points seen from view 0 mostly carry view 0's colour there (occluded ones need not).
    assert np.median(difference.max(axis=1)) < 25


def test_densified_depth_matches_the_rendered_depth(scene, arc, arc_result):
    cameras, _ = arc
    truth = render_view(scene, cameras[1], K, WIDTH, HEIGHT).depth
    estimate = arc_result.depths[1]
    rows, cols = np.nonzero(estimate > 0)
    h, w = estimate.shape
    true_depth = truth[np.round(rows * HEIGHT / h).astype(int), np.round(cols * WIDTH / w).astype(int)]
    known = true_depth > 0
    ratio = true_depth[known] / estimate[rows, cols][known]
    relative_error = np.abs(ratio / np.median(ratio) - 1.0)
    assert np.mean(relative_error < 0.05) > 0.9


def test_each_point_says_how_many_views_support_it(arc_result):
    """The points' confidence: a triangulated point's track length, a dense one's agreeing views."""
    support = arc_result.point_confidence
    assert support is not None and len(support) == arc_result.num_points
    assert support.min() >= 2 and support.max() <= arc_result.num_views


def test_densify_adds_points_beyond_the_sparse_matches(arc, arc_result):
    sparse = ClassicalBackbone(densify=False).reconstruct(arc[1])
    assert sparse.depths is None
    assert sparse.num_points > 200
    assert arc_result.num_points > 5 * sparse.num_points


def test_downscaled_processing_reports_original_pixels(arc):
    result = ClassicalBackbone(max_image_side=320, densify=False).reconstruct(arc[1][:3])
    assert result.registered.all()
    np.testing.assert_allclose(result.intrinsics[0], guess_intrinsics(WIDTH, HEIGHT, 60.0), atol=1e-9)
    true_rotation, _ = relative_pose(arc[0][0], arc[0][2])
    rotation, _ = relative_pose(result.extrinsics[0], result.extrinsics[2])
    assert rotation_error_deg(rotation, true_rotation) < 5.0


def test_turning_in_place_gives_rotations_and_no_baseline(scene):
    cameras = turning_cameras(scene)
    images = [render_view(scene, camera, K, WIDTH, HEIGHT).rgb for camera in cameras]
    result = ClassicalBackbone().reconstruct(images)
    assert result.registered.all(), result.warnings
    for index in range(len(cameras) - 1):
        true_rotation, _ = relative_pose(cameras[index], cameras[index + 1])
        rotation, translation = relative_pose(result.extrinsics[index], result.extrinsics[index + 1])
        assert rotation_error_deg(rotation, true_rotation) < 2.0
        assert np.linalg.norm(translation) < 1e-9
    assert any("depth is undefined" in warning for warning in result.warnings)
    np.testing.assert_allclose(np.linalg.norm(result.points, axis=1), 1.0, rtol=1e-5)
    assert result.depths is None


def test_four_sides_of_an_object_register_with_accurate_poses():
    """MindCube's "among": front, left, back and right of a central object, 90 degrees apart.

    Neighbouring views see the floor foreshortened in directions 90 degrees apart; only the
    simulated tilts give enough correct matches to place them all."""
    among_scene = generate_scene(AMONG_SEED)
    rig = among_rig(among_scene, np.random.default_rng(AMONG_SEED))
    assert rig is not None
    images = [render_view(among_scene, camera, K, WIDTH, HEIGHT).rgb for camera in rig.extrinsics]
    result = ClassicalBackbone(densify=False).reconstruct(images)
    assert result.registered.all(), result.warnings
    for index in range(len(images) - 1):
        true_rotation, true_translation = relative_pose(rig.extrinsics[index], rig.extrinsics[index + 1])
        rotation, translation = relative_pose(result.extrinsics[index], result.extrinsics[index + 1])
        assert rotation_error_deg(rotation, true_rotation) < 5.0
        assert direction_error_deg(translation, true_translation) < 15.0


def test_tilted_keypoints_map_back_and_match_once(arc):
    gray = arc[1][0].mean(axis=2).astype(np.uint8)
    features = detect_features(gray, 2000)
    assert len(features.descriptors) == len(features.owners) > len(features)
    assert set(np.unique(features.owners).tolist()) == set(range(len(features)))  # none without one
    assert (features.keypoints >= -1).all() and (features.keypoints <= [WIDTH, HEIGHT]).all()
    # Matching an image with itself pairs every matched keypoint with itself, each at most once.
    matches = match_features(features, features)
    assert len(matches) > 0.5 * len(features)
    assert (matches[:, 0] == matches[:, 1]).all()
    assert len(np.unique(matches[:, 0])) == len(matches)


def test_unrelated_and_blank_views_are_flagged_not_invented(scene, arc):
    cameras, images = arc
    blank = np.full((HEIGHT, WIDTH, 3), 128, np.uint8)
    other_scene = generate_scene(SCENE_SEED + 7)
    unrelated = render_view(other_scene, turning_cameras(other_scene, 1)[0], K, WIDTH, HEIGHT).rgb
    result = ClassicalBackbone(densify=False).reconstruct([images[0], blank, images[1], images[2], unrelated])
    assert result.registered.tolist() == [True, False, True, True, False], result.warnings
    assert np.isnan(result.extrinsics[[1, 4]]).all()
    assert any(warning.startswith("view 2 could not be registered") for warning in result.warnings)
    assert any(warning.startswith("view 5 could not be registered") for warning in result.warnings)
    true_rotation, _ = relative_pose(cameras[0], cameras[2])
    rotation, _ = relative_pose(result.extrinsics[0], result.extrinsics[3])  # images[2] sits at index 3
    assert rotation_error_deg(rotation, true_rotation) < 5.0
    # NaN poses of unplaced views survive the wire format.
    again = Reconstruction.from_bytes(result.to_bytes())
    assert again.registered.tolist() == result.registered.tolist()
    assert np.isnan(again.extrinsics[1]).all() and np.isfinite(again.extrinsics[0]).all()


def test_unplaceable_inputs_raise_clear_errors(arc):
    backbone = ClassicalBackbone()
    with pytest.raises(BackboneError, match="at least 2 images"):
        backbone.reconstruct(arc[1][:1])
    blank = np.full((HEIGHT, WIDTH, 3), 90, np.uint8)
    with pytest.raises(BackboneError, match="texture"):
        backbone.reconstruct([blank, blank.copy(), arc[1][0]])
    with pytest.raises(BackboneError, match="uint8 RGB"):
        backbone.reconstruct([arc[1][0], arc[1][1].astype(np.float32)])
    with pytest.raises(BackboneError, match="unknown options"):
        backbone.reconstruct(arc[1][:2], colour="blue")


def test_registry_builds_the_backbone_with_settings():
    backbone = create_backbone("classical", fov_deg=70.0, densify=False)
    assert isinstance(backbone, ClassicalBackbone)
    assert (backbone.name, backbone.fov_deg, backbone.densify) == ("classical", 70.0, False)
    with pytest.raises(BackboneError):
        ClassicalBackbone(fov_deg=200.0)


def test_intrinsics_survive_the_resize_round_trip():
    original = guess_intrinsics(1920, 1080, 60.0)
    assert original[0, 0] == pytest.approx(960.0 / np.tan(np.radians(30.0)))
    assert original[:2, 2].tolist() == [959.5, 539.5]
    working = intrinsics_after_resize(original, 0.5)
    assert working[:2, 2].tolist() == [479.5, 269.5]  # the centre stays the centre
    np.testing.assert_allclose(intrinsics_before_resize(working, 0.5), original)


def _synthetic_pair(translation: np.ndarray, seed: int = 3):
    """Random points in front of two cameras; pixels with 0.3 px noise."""
    rng = np.random.default_rng(seed)
    intrinsic = guess_intrinsics(640, 480, 60.0)
    points = rng.uniform([-2, -1.5, 3], [2, 1.5, 7], size=(300, 3))
    angle = np.radians(25.0)
    rotation = np.array([[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]])
    second = points @ rotation.T + translation
    first_pixels = points[:, :2] / points[:, 2:] * intrinsic[0, 0] + intrinsic[:2, 2]
    second_pixels = second[:, :2] / second[:, 2:] * intrinsic[0, 0] + intrinsic[:2, 2]
    first_pixels += rng.normal(0, 0.3, first_pixels.shape)
    second_pixels += rng.normal(0, 0.3, second_pixels.shape)
    matches = np.stack([np.arange(300), np.arange(300)], axis=1)
    return first_pixels, second_pixels, intrinsic, matches, rotation


def test_two_view_tells_pure_rotation_from_translation():
    first, second, intrinsic, matches, rotation = _synthetic_pair(np.zeros(3))
    turned = estimate_two_view(first, second, intrinsic, intrinsic, matches)
    assert turned is not None and turned.is_rotation
    assert rotation_error_deg(turned.rotation, rotation) < 0.5
    assert not turned.translation.any()

    step = np.array([-0.8, 0.1, 0.2])
    first, second, intrinsic, matches, rotation = _synthetic_pair(step)
    moved = estimate_two_view(first, second, intrinsic, intrinsic, matches)
    assert moved is not None and moved.model == "essential"
    assert rotation_error_deg(moved.rotation, rotation) < 0.5
    assert direction_error_deg(moved.translation, step) < 3.0
    assert len(moved.matches) > 250
