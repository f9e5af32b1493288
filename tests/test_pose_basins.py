"""Error bars that cover the error: another basin of a pair's pose, supported nearly as well by the
pair's own matches, widens the stated rotation uncertainty to the gap and is named (issue 36)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from services.recon.backbones.classical.geometry import compose, rotation_angle_deg
from services.recon.backbones.classical.pair_uncertainty import assess_pairs
from services.recon.backbones.classical.pose_basins import BASIN_SHARE, fits_as_well, rival_basin
from services.recon.backbones.classical.two_view import TwoViewGeometry, estimate_two_view
from services.recon.backbones.classical.verification import disagreement_with_pairs
from shared.geometry.reconstruction import PairConfidence

WIDTH, HEIGHT = 640, 480
FOCAL = WIDTH / 2 / math.tan(math.radians(12.0))  # a 24-degree lens, as templeRing's
INTRINSIC = np.array([[FOCAL, 0, WIDTH / 2], [0, FOCAL, HEIGHT / 2], [0, 0, 1]])


def _orbit(angle_deg: float, tilt_deg: float = 0.0) -> np.ndarray:
    """A camera on a circle of radius 10 around the origin looking at it, turned by `tilt_deg`
    about its own x axis (a pose the same centre does not explain)."""
    angle, tilt = math.radians(angle_deg), math.radians(tilt_deg)
    yaw = np.array([[math.cos(angle), 0, -math.sin(angle)], [0, 1, 0], [math.sin(angle), 0, math.cos(angle)]])
    pitch = np.array([[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]])
    rotation = pitch @ yaw
    return compose(rotation, rotation @ yaw.T @ np.array([0.0, 0.0, 10.0]))


def _matches(first: np.ndarray, second: np.ndarray, count: int, rng: np.random.Generator, noise: float = 0.1):
    """Pixels of `count` random points of an object at the origin, seen by both cameras."""
    points = rng.uniform([-2.0, -1.5, -1.5], [2.0, 1.5, 1.5], size=(count, 3))
    pixels = []
    for camera in (first, second):
        local = points @ camera[:, :3].T + camera[:, 3]
        pixels.append(
            local[:, :2] / local[:, 2:] * FOCAL + INTRINSIC[:2, 2] + rng.normal(0, noise, (count, 2))
        )
    return pixels


def _two_basins(truth: int, rival: int, rival_tilt_deg: float, seed: int = 4):
    """Matches of two views 20 degrees apart: `truth` of them agree with the true second camera,
    `rival` with a second camera turned `rival_tilt_deg` (a second basin of the pose: with as
    many matches each, the data cannot tell the two poses apart)."""
    rng = np.random.default_rng(seed)
    first = _orbit(0.0)
    true_pixels = _matches(first, _orbit(20.0), truth, rng)
    rival_pixels = _matches(first, _orbit(20.0, rival_tilt_deg), rival, rng)
    return [np.concatenate([a, b]) for a, b in zip(true_pixels, rival_pixels, strict=True)]


def _normalized(pixels: np.ndarray) -> np.ndarray:
    return (pixels - INTRINSIC[:2, 2]) / FOCAL


def _relative(camera: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and unit translation of `camera` in the frame of the first camera, _orbit(0)."""
    first = _orbit(0.0)
    rotation = camera[:, :3] @ first[:, :3].T
    translation = camera[:, 3] - rotation @ first[:, 3]
    return rotation, translation / np.linalg.norm(translation)


@pytest.mark.parametrize("tilt", [6.0, 11.0])
def test_a_second_solution_supported_nearly_as_well_is_found_with_its_gap(tilt: float) -> None:
    first, second = _two_basins(120, 120, tilt)
    rotation, translation = _relative(_orbit(20.0))
    basin = rival_basin(_normalized(first), _normalized(second), FOCAL, rotation, translation)
    assert basin is not None
    true_gap = rotation_angle_deg(_orbit(20.0, tilt)[:, :3] @ rotation.T)
    assert basin.gap_deg == pytest.approx(true_gap, abs=1.0)
    assert basin.support >= BASIN_SHARE * basin.model_support
    # a clear majority for one pose is no tie: the other basin is then no rival
    first, second = _two_basins(120, 90, tilt)
    assert rival_basin(_normalized(first), _normalized(second), FOCAL, rotation, translation) is None
    assert f"{true_gap:.0f} degrees away fits nearly as well" in basin.describe()


def test_a_second_solution_with_little_support_is_no_rival() -> None:
    first, second = _two_basins(200, 40, 11.0)
    rotation, translation = _relative(_orbit(20.0))
    assert rival_basin(_normalized(first), _normalized(second), FOCAL, rotation, translation) is None


def test_a_clean_wide_pair_has_no_rival_basin() -> None:
    first, second = _matches(_orbit(0.0), _orbit(20.0), 200, np.random.default_rng(5))
    rotation, translation = _relative(_orbit(20.0))
    assert rival_basin(_normalized(first), _normalized(second), FOCAL, rotation, translation) is None


def test_a_pose_in_the_wrong_basin_states_an_uncertainty_that_covers_its_error() -> None:
    """The pair's two-view fit lands in one basin; whichever it is, the other is named and the
    stated rotation uncertainty reaches the gap, so the true error is within one sigma."""
    pixels = _two_basins(120, 120, 11.0)
    matches = np.stack([np.arange(len(pixels[0]))] * 2, axis=1)
    geometry = estimate_two_view(pixels[0], pixels[1], INTRINSIC, INTRINSIC, matches)
    assert geometry is not None
    error = rotation_angle_deg(geometry.rotation @ _relative(_orbit(20.0))[0].T)
    extrinsics = {0: compose(np.eye(3), np.zeros(3)), 1: compose(geometry.rotation, geometry.translation)}
    tracks = [{0: int(a), 1: int(b)} for a, b in geometry.matches]
    confidence = [PairConfidence(0, 1, len(tracks), 0.5, 20.0)]
    [pair] = assess_pairs(pixels, [INTRINSIC] * 2, extrinsics, tracks, {(0, 1): geometry}, confidence)
    assert pair.rotation_uncertainty_deg >= 10.0 and error <= 2 * pair.rotation_uncertainty_deg
    assert pair.uncertain_reason is not None and "fits nearly as well" in pair.uncertain_reason
    geometry_blind = type(geometry)(**{**geometry.__dict__, "candidates": None})
    [blind] = assess_pairs(pixels, [INTRINSIC] * 2, extrinsics, tracks, {(0, 1): geometry_blind}, confidence)
    assert blind.rotation_uncertainty_deg < 2.0  # the curvature alone: it cannot see the other basin


def test_a_pose_in_a_basin_the_matches_support_as_well_fits_as_well_and_one_they_reject_does_not() -> None:
    """Verification asks this before refusing a view whose model pose disagrees with a pair's own
    fit: the pair's fit may sit in the other of two basins its matches support alike."""
    first, second = _two_basins(120, 120, 11.0)
    n1, n2 = _normalized(first), _normalized(second)
    true_rotation, true_translation = _relative(_orbit(20.0))
    rival_rotation, rival_translation = _relative(_orbit(20.0, 11.0))
    # a fit in either basin: the pose of the other fits as well (a tie, derived from the counts)
    assert fits_as_well(n1, n2, FOCAL, rival_rotation, rival_translation, true_rotation, true_translation)
    assert fits_as_well(n1, n2, FOCAL, true_rotation, true_translation, rival_rotation, rival_translation)
    # one basin only: a pose 11 degrees off, which no match supports, does not fit as well
    first, second = _two_basins(240, 0, 11.0)
    n1, n2 = _normalized(first), _normalized(second)
    assert not fits_as_well(n1, n2, FOCAL, rival_rotation, rival_translation, true_rotation, true_translation)
    # and the true pose fits as well as itself
    assert fits_as_well(n1, n2, FOCAL, true_rotation, true_translation, true_rotation, true_translation)


@pytest.mark.parametrize("rival", [120, 0])
def test_verification_refuses_a_view_only_when_the_pairs_matches_prefer_their_own_pose(rival: int) -> None:
    """A model pose 11 degrees from the pair's two-view fit. Two basins supported alike (`rival`
    matches for the second): the pair says nothing against the model, no refusal. One basin, the
    pair's: the model's pose is one the matches reject, and the view is refused."""
    pixels = _two_basins(120 + (120 - rival), rival, 11.0)
    matches = np.stack([np.arange(len(pixels[0]))] * 2, axis=1)
    true_pose, rival_pose = _relative(_orbit(20.0)), _relative(_orbit(20.0, 11.0))
    # the pair's own fit in the true basin; the model places the view in the other one
    pair = TwoViewGeometry(matches, *true_pose, "essential", 10.0, candidates=matches)
    extrinsics = {0: compose(np.eye(3), np.zeros(3)), 1: compose(*rival_pose)}
    pairs = {(0, 1): pair}
    reason = disagreement_with_pairs(1, extrinsics, pairs, pixels, {0: INTRINSIC, 1: INTRINSIC})
    if rival:
        assert reason is None
    else:
        assert reason is not None and "disagrees with its matches" in reason
    # without the matches to weigh, any disagreement over 5 degrees refuses the view (as before)
    assert disagreement_with_pairs(1, extrinsics, pairs) is not None
