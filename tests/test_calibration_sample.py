"""The calibration rounds' track sample: bounded, spread, deterministic; the rest follow its poses."""

from __future__ import annotations

import numpy as np

from services.recon.backbones.classical.calibration_sample import (
    CALIBRATION_TRACKS,
    adjusted_coarse_to_fine,
    calibration_sample,
    sampled,
    with_sample_adjusted,
)
from services.recon.backbones.classical.geometry import project
from services.recon.backbones.classical.incremental import SparseModel

SIZE = (640, 480)
K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])


def _rotation_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _scene(count: int, seed: int = 3) -> tuple[SparseModel, list[np.ndarray]]:
    """`count` points in front of three cameras, each track seen by two or three of them."""
    rng = np.random.default_rng(seed)
    # The first four fifths crowd one corner of the first image, the rest spread over it; 4 to 6
    # units deep.
    crowded = count * 4 // 5
    pixels = np.vstack(
        [
            rng.uniform([0, 0], [100, 80], size=(crowded, 2)),
            rng.uniform([0, 0], SIZE, size=(count - crowded, 2)),
        ]
    )
    depth = rng.uniform(4, 6, size=(count, 1))
    points = np.hstack([(pixels - K[:2, 2]) / K[0, 0], np.ones((count, 1))]) * depth
    extrinsics = {}
    for view, angle in enumerate((0.0, 0.1, 0.2)):
        rotation = _rotation_y(angle)
        extrinsics[view] = np.hstack([rotation, (-rotation @ np.array([angle * 5, 0, 0]))[:, None]])
    keypoints, tracks = [], [{} for _ in range(count)]
    for view, extrinsic in extrinsics.items():
        pixels, _ = project(points, extrinsic, K)
        keypoints.append(pixels)
        for index in range(count):
            if view < 2 or index % 2 == 0:  # the third view sees every other point
                tracks[index][view] = index
    return SparseModel(extrinsics, points, tracks, False), keypoints


def test_small_models_use_every_track():
    model, keypoints = _scene(CALIBRATION_TRACKS)
    assert calibration_sample(model, keypoints, [SIZE] * 3) is None
    assert sampled(model, None) is model


def test_sample_is_bounded_spread_longest_first_and_deterministic():
    model, keypoints = _scene(2000)
    sample = calibration_sample(model, keypoints, [SIZE] * 3)
    assert sample == calibration_sample(model, keypoints, [SIZE] * 3)
    assert len(sample) == CALIBRATION_TRACKS == len(set(sample))
    chosen = keypoints[0][sample]
    # Spread: every cell of a 6x6 grid over the first image holds some of the sample.
    cells = {(int(x / SIZE[0] * 6), int(y / SIZE[1] * 6)) for x, y in chosen}
    assert cells == {(i, j) for i in range(6) for j in range(6)}
    # Longest first: three-view tracks are half the model but more than half the sample.
    assert sum(len(model.tracks[i]) == 3 for i in sample) > CALIBRATION_TRACKS * 0.6


def test_other_tracks_are_retriangulated_on_the_sample_poses():
    model, keypoints = _scene(800)
    sample = calibration_sample(model, keypoints, [SIZE] * 3)
    stale = SparseModel(model.extrinsics, model.points + 0.3, model.tracks, False)
    adjusted = sampled(model, sample)  # the sample as adjustment would leave it: exact here
    merged = with_sample_adjusted(stale, sample, adjusted, keypoints, [K] * 3)
    assert len(merged.tracks) == len(model.tracks)
    np.testing.assert_allclose(merged.points, model.points, atol=1e-6)
    assert set(merged.extrinsics) == set(adjusted.extrinsics)


def test_coarse_to_fine_reaches_the_focal_from_a_far_prior():
    """From a focal 1.6x too short the staged adjustment ends where one adjustment does: the focal
    the projections were made with, and the result is for every track, in order."""
    model, keypoints = _scene(800)
    noisy = [
        pixels + np.random.default_rng(view).normal(0, 0.3, pixels.shape)
        for view, pixels in enumerate(keypoints)
    ]
    short = K.copy()
    short[0, 0] = short[1, 1] = 500.0 / 1.6
    free = [True] * 3
    staged = adjusted_coarse_to_fine(noisy, [SIZE] * 3, [short] * 3, free, model, True, 300)
    single = adjusted_coarse_to_fine(noisy, [SIZE] * 3, [short] * 3, free, model, True, 300, staged=False)
    assert staged.usable and staged.points.shape == model.points.shape
    assert abs(staged.intrinsics[0][0, 0] - 500.0) < 10.0
    assert abs(staged.intrinsics[0][0, 0] - single.intrinsics[0][0, 0]) < 2.0
    fixed = adjusted_coarse_to_fine(noisy, [SIZE] * 3, [short] * 3, free, model, False)
    assert fixed.intrinsics[0][0, 0] == short[0, 0]  # the focal stays put when not refined
