"""What self-calibration may skip: homography fits at a new focal, a prior check already settled."""

from __future__ import annotations

import numpy as np

from services.recon.backbones.classical.bundle_adjustment import track_costs
from services.recon.backbones.classical.calibration_sample import coarse_stage
from services.recon.backbones.classical.geometry import compose, project
from services.recon.backbones.classical.incremental import SparseModel
from services.recon.backbones.classical.solve import MAX_PRIOR_COST_RISE, _evidently_dearer
from services.recon.backbones.classical.two_view import estimate_two_view, fit_homography

SIZE = (640, 480)
FOCAL = 800.0


def _intrinsic(focal: float) -> np.ndarray:
    return np.array([[focal, 0, SIZE[0] / 2], [0, focal, SIZE[1] / 2], [0, 0, 1]])


def _turn(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _cameras(count: int) -> dict[int, np.ndarray]:
    """Cameras on an arc around the origin, 8 units away, 8 degrees apart, looking at it
    (3x4 camera-from-world [R|t], OpenCV axes)."""
    return {view: compose(_turn(np.radians(8.0 * view)), np.array([0.0, 0.0, 8.0])) for view in range(count)}


def _observed(points: np.ndarray, cameras: dict[int, np.ndarray], seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [
        project(points, cameras[view], _intrinsic(FOCAL))[0] + rng.normal(0, 0.4, (len(points), 2))
        for view in cameras
    ]


def test_a_homography_fit_is_the_same_at_any_focal_and_spares_the_refit():
    """Half the matches lie on a plane (a homography explains them), half off it; fitted at the
    true focal and at 0.6x, the fit keeps the same inliers and pixel homography (to its refinement's
    tolerance), and the two-view geometry given a fit made at another focal is the one fitted from
    scratch."""
    rng = np.random.default_rng(4)
    plane = np.column_stack([rng.uniform(-2, 2, 150), rng.uniform(-1.5, 1.5, 150), np.zeros(150)])
    solid = rng.uniform([-2, -1.5, -1.5], [2, 1.5, 1.5], size=(150, 3))
    pixels = _observed(np.vstack([plane, solid]), _cameras(2), seed=5)
    matches = np.stack([np.arange(300), np.arange(300)], axis=1)
    true_k, short_k = _intrinsic(FOCAL), _intrinsic(0.6 * FOCAL)
    at_truth = fit_homography(pixels[0], pixels[1], true_k, true_k, matches)
    at_short = fit_homography(pixels[0], pixels[1], short_k, short_k, matches)
    assert at_truth.pixels is not None and at_short.pixels is not None
    assert at_truth.inliers[:150].mean() > 0.9 > at_truth.inliers[150:].mean()
    np.testing.assert_array_equal(at_truth.inliers, at_short.inliers)
    # The same homography up to its refinement's tolerance: it moves every match to within 0.01 px.
    moved = [_transfer(fit.pixels, pixels[0]) for fit in (at_truth, at_short)]
    assert np.max(np.linalg.norm(moved[0] - moved[1], axis=1)) < 0.01
    fresh = estimate_two_view(pixels[0], pixels[1], true_k, true_k, matches)
    reused = estimate_two_view(pixels[0], pixels[1], true_k, true_k, matches, at_short)
    assert fresh is not None and reused is not None
    assert fresh.model == reused.model and fresh.rivals.homography_inliers == reused.rivals.homography_inliers
    np.testing.assert_allclose(fresh.rotation, reused.rotation, atol=1e-9)
    normalized = (pixels[0] - true_k[:2, 2]) / FOCAL
    difference = _transfer(fresh.rivals.homography, normalized) - _transfer(
        reused.rivals.homography, normalized
    )
    assert np.max(np.linalg.norm(difference, axis=1)) * FOCAL < 0.01


def _transfer(homography: np.ndarray, points: np.ndarray) -> np.ndarray:
    mapped = np.column_stack([points, np.ones(len(points))]) @ homography.T
    return mapped[:, :2] / mapped[:, 2:]


def _walk_model(count: int = 600) -> tuple[SparseModel, list[np.ndarray]]:
    """Points 5-9 units deep seen by four cameras stepping sideways and up while turning, their
    optical axes not meeting at one point (so the focal is observable): every track in every view."""
    rng = np.random.default_rng(6)
    points = rng.uniform([-2, -1.5, 5], [2, 1.5, 9], size=(count, 3))
    cameras = {
        view: compose(_turn(np.radians(5.0 * view)), np.array([-0.8 * view, 0.3 * view, 0.0]))
        for view in range(4)
    }
    keypoints = _observed(points, cameras, seed=7)
    tracks = [dict.fromkeys(cameras, index) for index in range(count)]
    return SparseModel(cameras, points, tracks, False), keypoints


def test_the_prior_check_stops_early_only_when_the_prior_is_evidently_dearer():
    """Moved to a focal 1.6x too short, the coarse stage already costs far more than the bound;
    at the true focal (the estimate itself), the excess is within the noise and the check goes on."""
    model, keypoints = _walk_model()
    free = [True] * 4
    truth = [_intrinsic(FOCAL)] * 4
    calibrated = track_costs(keypoints, dict(enumerate(truth)), model.extrinsics, model.points, model.tracks)
    bound = MAX_PRIOR_COST_RISE * calibrated
    far = coarse_stage(keypoints, [SIZE] * 4, [_intrinsic(FOCAL / 1.6)] * 4, free, model, False)
    same = coarse_stage(keypoints, [SIZE] * 4, truth, free, model, False)
    assert far.tracks is not None and same.tracks is not None
    assert _evidently_dearer(keypoints, far, bound)
    assert not _evidently_dearer(keypoints, same, bound)
