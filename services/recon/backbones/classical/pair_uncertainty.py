"""How uncertain each pair's relative pose is, and which degenerate configuration makes it so.

The uncertainty is the larger of two: the gap to another basin of the pose that the pair's own
matches support nearly as well (pose_basins: the twisted pair, the mirrored solution, RANSAC
restarts), and the linearised covariance of the pair's relative pose (3 rotation and 2
direction parameters) under the Sampson errors of the matches both views share in the model,
scaled by their measured noise: sigma^2 (J^T J)^-1 at the model's pose. It is cheap (a 5-column
Jacobian by central differences) and it sees the ambiguity that fooled the pose: with a narrow
lens and a short baseline, a turn and a sideways step move the image alike, so the cost has a
long flat valley along which the rotation is poorly fixed even by a hundred sub-pixel matches.

A pair is flagged when its rotation is uncertain by more than MAX_ROTATION_SIGMA_DEG, or its
rays meet at an angle that is small against that uncertainty, or when a second model explains
its matches about as well: a turn in place (near-pure rotation), one homography (near-planar), or
another pose of the essential matrix that the other views do not settle (pose_basins).
The reason names the configuration.
"""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np

from shared.geometry.reconstruction import PairConfidence

from .geometry import (
    normalized_coordinates,
    rotation_angle_deg,
    rotation_from_vector,
    sampson_distances,
)
from .pose_basins import RivalBasin, rival_basin
from .two_view import TwoViewGeometry

MAX_ROTATION_SIGMA_DEG = 1.5  # one standard deviation; 3 sigma (4.5) stays under a 5-degree error
MIN_ANGLE_OVER_SIGMA = 8.0  # triangulation angle against the rotation's standard deviation
RIVAL_SHARE = 0.9  # a second model explaining this share of the essential inliers is a rival
RIVAL_GAP_DEG = 2.0  # ... when the pose it implies is this far from the essential model's
# Below this triangulation angle any scene's image motion is close to a homography, and its
# decompositions fit the matches alike (a synthetic room 1-2 cm apart: 2-3 degrees apart, same
# errors); that is the small-angle case, flagged by MIN_ANGLE_OVER_SIGMA, not a plane.
MIN_PLANAR_ANGLE_DEG = 5.0
RIVAL_FIT_RATIO = 1.5  # a homography's pose "fits as well" within this ratio of median epipolar errors
MIN_NOISE_PX = 0.25  # the noise floor: keypoints are not located better than this
MIN_SHARED = 8
OUTLIER_PX = 3.0
STEP = 1e-6


def assess_pairs(
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    extrinsics: dict[int, np.ndarray],
    tracks: list[dict[int, int]],
    pairs: dict[tuple[int, int], TwoViewGeometry],
    confidence: list[PairConfidence],
) -> list[PairConfidence]:
    """Each pair's confidence with its uncertainty and, when flagged, the reason."""
    direct, planar_gaps, basins = [], [], []
    for pair in confidence:
        rays = _shared_rays(keypoints, intrinsics, extrinsics, tracks, pair.first, pair.second)
        rotation_sigma, direction_sigma = _pose_sigmas(*rays)
        geometry = pairs.get((pair.first, pair.second))
        basin = _rival_basin(keypoints, intrinsics, geometry, pair.first, pair.second, rays)
        if basin is not None and math.isfinite(rotation_sigma):
            rotation_sigma = max(rotation_sigma, basin.gap_deg)  # the other basin is as likely
        basins.append(basin)
        direct.append(
            replace(pair, rotation_uncertainty_deg=rotation_sigma, direction_uncertainty_deg=direction_sigma)
        )
        wide = pair.triangulation_angle_deg >= MIN_PLANAR_ANGLE_DEG
        planar_gaps.append(_planar_rival_gap(*rays, geometry) if wide else 0.0)
    through_model = _chained_sigmas(direct)
    result = []
    for pair, planar_gap, basin in zip(direct, planar_gaps, basins, strict=True):
        updated = replace(pair, rotation_uncertainty_deg=through_model[(pair.first, pair.second)])
        # The other views settle a pair's basin when a chain through them is tighter than the gap.
        unsettled = (
            basin if basin is not None and updated.rotation_uncertainty_deg >= basin.gap_deg / 2 else None
        )
        reason = uncertain_reason(updated, pairs.get((pair.first, pair.second)), planar_gap, unsettled)
        result.append(replace(updated, uncertain_reason=reason))
    return result


def _rival_basin(
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    geometry: TwoViewGeometry | None,
    first: int,
    second: int,
    rays: _Rays,
) -> RivalBasin | None:
    """Another pose the pair's own matches support nearly as well as the model's (pose_basins)."""
    if geometry is None or geometry.candidates is None or geometry.model != "essential":
        return None
    matches = geometry.candidates
    n1 = normalized_coordinates(keypoints[first][matches[:, 0]], intrinsics[first])
    n2 = normalized_coordinates(keypoints[second][matches[:, 1]], intrinsics[second])
    _, _, focal, rotation, translation = rays
    return rival_basin(n1, n2, focal, rotation, translation)


def _chained_sigmas(pairs: list[PairConfidence]) -> dict[tuple[int, int], float]:
    """Per pair the rotation uncertainty through the model: the best chain of direct pairs.

    Two views 46-69 degrees apart share few points, so their direct estimate is loose, yet the
    model fixes their relative rotation through the views between them; the variances of a chain
    add up (independent errors), and the best chain bounds the uncertainty (Floyd-Warshall)."""
    views = sorted({p.first for p in pairs} | {p.second for p in pairs})
    index = {view: position for position, view in enumerate(views)}
    variance = np.full((len(views), len(views)), np.inf)
    np.fill_diagonal(variance, 0.0)
    for pair in pairs:
        sigma = pair.rotation_uncertainty_deg
        if math.isfinite(sigma):
            a, b = index[pair.first], index[pair.second]
            variance[a, b] = variance[b, a] = sigma**2
    for middle in range(len(views)):
        variance = np.minimum(variance, variance[:, middle : middle + 1] + variance[middle : middle + 1, :])
    chained = {(p.first, p.second): float(variance[index[p.first], index[p.second]]) for p in pairs}
    return {key: math.sqrt(value) if math.isfinite(value) else math.nan for key, value in chained.items()}


_Rays = tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]


def _shared_rays(
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    extrinsics: dict[int, np.ndarray],
    tracks: list[dict[int, int]],
    first: int,
    second: int,
) -> _Rays:
    """The matches both views share in the model (normalized coordinates), the focal that turns
    them into pixels, and the model's relative pose (rotation, unit translation or zeros)."""
    shared = np.array(
        [(track[first], track[second]) for track in tracks if first in track and second in track],
        dtype=np.int64,
    ).reshape(-1, 2)
    n1 = normalized_coordinates(keypoints[first][shared[:, 0]], intrinsics[first])
    n2 = normalized_coordinates(keypoints[second][shared[:, 1]], intrinsics[second])
    focal = float(np.mean([intrinsics[first][0, 0], intrinsics[second][0, 0]]))
    rotation = extrinsics[second][:, :3] @ extrinsics[first][:, :3].T
    translation = extrinsics[second][:, 3] - rotation @ extrinsics[first][:, 3]
    length = float(np.linalg.norm(translation))
    return n1, n2, focal, rotation, translation / length if length > 1e-12 else np.zeros(3)


def uncertain_reason(
    pair: PairConfidence,
    geometry: TwoViewGeometry | None,
    planar_gap_deg: float = 0.0,
    basin: RivalBasin | None = None,
) -> str | None:
    """Why a pair's relative pose is not confident, naming the configuration; None when it is.

    `planar_gap_deg`: how far the pose of a homography's other decomposition is, when that pose
    explains the matches as well as the model's (0 when none does). `basin`: another pose of the
    essential matrix the matches support nearly as well, that the other views do not settle."""
    sigma, angle = pair.rotation_uncertainty_deg, pair.triangulation_angle_deg
    causes = [] if geometry is None or geometry.model != "essential" else _turn_rival(geometry)
    if basin is not None and basin.gap_deg > RIVAL_GAP_DEG:
        causes.append(basin.describe())
    if planar_gap_deg > RIVAL_GAP_DEG:
        causes.append(
            f"near-planar: one homography explains the matches as well with a pose {planar_gap_deg:.0f} "
            "degrees away"
        )
    if math.isfinite(sigma) and math.isfinite(angle) and angle < MIN_ANGLE_OVER_SIGMA * sigma:
        causes.append(f"small triangulation angle ({angle:.1f} degrees against that uncertainty)")
    if not math.isfinite(sigma) or sigma > MAX_ROTATION_SIGMA_DEG or causes:
        uncertainty = f"+-{sigma:.1f} degrees" if math.isfinite(sigma) else "not measurable"
        return f"relative rotation uncertain ({uncertainty})" + "".join(f"; {cause}" for cause in causes)
    return None


def _turn_rival(geometry: TwoViewGeometry) -> list[str]:
    """A turn in place explaining the matches about as well and disagreeing on the rotation.

    A rival that agrees on the rotation is no ambiguity (at a tiny baseline every scene fits a
    turn, and its rotation is the essential model's own); one more than RIVAL_GAP_DEG away is."""
    rivals = geometry.rivals
    if rivals.turn is None or rivals.rotation_inliers < RIVAL_SHARE * rivals.essential_inliers:
        return []
    gap = rotation_angle_deg(rivals.turn @ geometry.rotation.T)
    if gap <= RIVAL_GAP_DEG:
        return []
    return [f"near-pure rotation: a turn in place explains the matches about as well, {gap:.0f} degrees away"]


def _planar_rival_gap(
    n1: np.ndarray,
    n2: np.ndarray,
    focal: float,
    rotation: np.ndarray,
    translation: np.ndarray,
    geometry: TwoViewGeometry | None,
) -> float:
    """How far (degrees) the farthest homography decomposition that fits the matches as well is.

    A plane seen from two places fits two poses equally (the homography's two physical
    decompositions); a tiny baseline fits a homography too, but its other decomposition is
    noise and leaves epipolar errors well above the model's, so it is no rival."""
    if geometry is None or geometry.rivals.homography is None or len(n1) < MIN_SHARED:
        return 0.0
    rivals = geometry.rivals
    if rivals.homography_inliers < RIVAL_SHARE * rivals.essential_inliers or not translation.any():
        return 0.0
    own = _typical(sampson_distances(n1, n2, rotation, translation) * focal)
    _, rotations, translations, _ = cv2.decomposeHomographyMat(rivals.homography, np.eye(3))
    widest = 0.0
    for other_rotation, other_translation in zip(rotations, translations, strict=True):
        length = float(np.linalg.norm(other_translation))
        if length < 1e-12:
            continue
        fit = _typical(sampson_distances(n1, n2, other_rotation, other_translation.ravel() / length) * focal)
        if fit <= RIVAL_FIT_RATIO * max(own, MIN_NOISE_PX):
            widest = max(widest, rotation_angle_deg(other_rotation @ rotation.T))
    return widest


def _typical(errors: np.ndarray) -> float:
    """Median absolute error: the few matches neither pose explains do not decide."""
    finite = np.abs(errors[np.isfinite(errors)])
    return float(np.median(finite)) if len(finite) else math.inf


def _pose_sigmas(
    n1: np.ndarray, n2: np.ndarray, focal: float, rotation: np.ndarray, translation: np.ndarray
) -> tuple[float, float]:
    """Standard deviations (degrees) of the relative rotation and of the direction of travel."""
    if len(n1) < MIN_SHARED or not translation.any():
        return math.nan, math.nan
    across = np.linalg.svd(translation.reshape(1, 3))[2][1:]  # two unit vectors orthogonal to t

    def residuals(parameters: np.ndarray, keep: slice | np.ndarray = slice(None)) -> np.ndarray:
        turned = rotation_from_vector(parameters[:3]) @ rotation
        moved = translation + parameters[3:] @ across
        return sampson_distances(n1[keep], n2[keep], turned, moved / np.linalg.norm(moved)) * focal

    # Matches the model's pose does not explain (beyond OUTLIER_PX) would only inflate the noise.
    kept = np.abs(residuals(np.zeros(5))) < OUTLIER_PX
    if kept.sum() < MIN_SHARED:
        return math.nan, math.nan
    n1, n2 = n1[kept], n2[kept]
    base = residuals(np.zeros(5))
    jacobian = np.empty((len(base), 5))
    for column in range(5):
        step = np.zeros(5)
        step[column] = STEP
        jacobian[:, column] = (residuals(step) - residuals(-step)) / (2 * STEP)
    noise = max(float(np.sum(base**2) / max(len(base) - 5, 1)), MIN_NOISE_PX**2)
    try:
        covariance = noise * np.linalg.inv(jacobian.T @ jacobian)
    except np.linalg.LinAlgError:
        return math.inf, math.inf
    rotation_sigma = math.sqrt(max(float(np.linalg.eigvalsh(covariance[:3, :3])[-1]), 0.0))
    direction_sigma = math.sqrt(max(float(np.linalg.eigvalsh(covariance[3:, 3:])[-1]), 0.0))
    return math.degrees(rotation_sigma), math.degrees(direction_sigma)


MIN_MEASURED_POINTS = 15  # shared points with which a pair measures its own direction


def flag_guessed_distances(
    pairs: list[PairConfidence], tracks: list[dict[int, int]], guessed: dict[int, int]
) -> list[PairConfidence]:
    """The pairs, with those whose relative direction may rest on a guessed distance flagged.

    A view the mapper placed at a guessed distance from its anchor (it shares no 3D points with the
    views placed before it) has a measured direction from the anchor, but its position against any
    other view is built on the guess, unless a point seen by it and two other views ties its
    distance to theirs. Later views registered on its points inherit the guess too. So while such a
    view stays untied, a pair that does not measure its own direction (fewer than
    MIN_MEASURED_POINTS shared points) is flagged: its direction came through the model, and the
    model's distances are partly guessed (synthetic "among" rig, seed 3, 80 degree lens: views 2
    and 4 share no point and their direction came out 33 degrees off)."""
    untied = sorted(
        view for view in guessed if not any(view in track and len(track) >= 3 for track in tracks)
    )
    if not untied:
        return pairs
    names = ", ".join(f"view {view + 1} (from view {guessed[view] + 1})" for view in untied)
    flagged = []
    for pair in pairs:
        if pair.inliers < MIN_MEASURED_POINTS:
            reason = (
                f"their direction is not measured ({pair.inliers} shared points) and the model places "
                f"{names} at a guessed distance, so it may rest on the guess"
            )
            given = pair.uncertain_reason
            pair = replace(pair, uncertain_reason=f"{given}; {reason}" if given else reason)
        flagged.append(pair)
    return flagged
