"""A view verification refused is placed again on the adjusted model of the others (issue 36):
by PnP on the model's points its matches reach, with those observations added to their tracks."""

from __future__ import annotations

import math

import numpy as np

from services.recon.backbones.classical.geometry import compose, project, rotation_angle_deg
from services.recon.backbones.classical.incremental import SparseModel
from services.recon.backbones.classical.reregistration import with_views_placed_again
from services.recon.backbones.classical.two_view import TwoViewGeometry

FOCAL = 800.0
INTRINSIC = np.array([[FOCAL, 0, 320.0], [0, FOCAL, 240.0], [0, 0, 1]])


def _orbit(angle_deg: float) -> np.ndarray:
    angle = math.radians(angle_deg)
    cos, sin = math.cos(angle), math.sin(angle)
    rotation = np.array([[cos, 0, -sin], [0, 1, 0], [sin, 0, cos]])
    return compose(rotation, np.array([0.0, 0.0, 10.0]))


def _scene(seed: int = 3):
    """Three cameras around 200 points; keypoint i of every view is point i (with pixel noise)."""
    rng = np.random.default_rng(seed)
    points = rng.uniform(-2.0, 2.0, size=(200, 3))
    cameras = [_orbit(angle) for angle in (0.0, 15.0, 30.0)]
    keypoints = [project(points, camera, INTRINSIC)[0] + rng.normal(0, 0.3, (200, 2)) for camera in cameras]
    every = np.stack([np.arange(200), np.arange(200)], axis=1)
    pairs = {
        key: TwoViewGeometry(every, np.eye(3), np.array([1.0, 0, 0]), "essential", 10.0)
        for key in ((0, 1), (0, 2), (1, 2))
    }
    # views 0 and 1 adjusted (here: their true poses), view 2 refused earlier
    model = SparseModel(
        {0: cameras[0], 1: cameras[1]}, points.copy(), [{0: i, 1: i} for i in range(200)], False
    )
    return keypoints, pairs, model, cameras


def test_a_refused_view_is_placed_again_on_the_model_with_its_observations() -> None:
    keypoints, pairs, model, cameras = _scene()
    placed_model, placed = with_views_placed_again(keypoints, [INTRINSIC] * 3, pairs, model, [2])
    assert placed == [2]
    error = rotation_angle_deg(placed_model.extrinsics[2][:, :3] @ cameras[2][:, :3].T)
    assert error < 0.2
    assert np.linalg.norm(placed_model.extrinsics[2][:, 3] - cameras[2][:, 3]) < 0.05
    joined = sum(2 in track for track in placed_model.tracks)
    assert joined >= 0.9 * len(model.tracks)
    assert all(track[2] == point for point, track in enumerate(placed_model.tracks) if 2 in track)
    # the input model is left as it was
    assert 2 not in model.extrinsics and all(2 not in track for track in model.tracks)


def test_a_view_whose_matches_reach_no_consistent_pose_stays_refused() -> None:
    keypoints, pairs, model, _ = _scene()
    scrambled = [keypoints[0], keypoints[1], np.random.default_rng(9).permutation(keypoints[2])]
    placed_model, placed = with_views_placed_again(scrambled, [INTRINSIC] * 3, pairs, model, [2])
    assert placed == [] and placed_model is model
