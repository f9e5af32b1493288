"""How uncertain each pair's relative pose is, and which degenerate configuration makes it so.

The uncertainty is the linearised covariance of the pair's relative pose (3 rotation and 2
direction parameters) under the Sampson errors of the matches both views share in the model,
scaled by their measured noise: sigma^2 (J^T J)^-1 at the model's pose. It is cheap (a 5-column
Jacobian by central differences) and it sees the ambiguity that fooled the pose: with a narrow
lens and a short baseline, a turn and a sideways step move the image alike, so the cost has a
long flat valley along which the rotation is poorly fixed even by a hundred sub-pixel matches.

A pair is flagged when its rotation is uncertain by more than MAX_ROTATION_SIGMA_DEG, or its
rays meet at an angle that is small against that uncertainty, or when a second model explains
its matches about as well: a turn in place (near-pure rotation) or one homography (near-planar).
The reason names the configuration.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from shared.geometry.reconstruction import PairConfidence

from .geometry import normalized_coordinates
from .two_view import TwoViewGeometry

MAX_ROTATION_SIGMA_DEG = 1.5  # one standard deviation; 3 sigma (4.5) stays under a 5-degree error
MIN_ANGLE_OVER_SIGMA = 8.0  # triangulation angle against the rotation's standard deviation
RIVAL_SHARE = 0.9  # a second model explaining this share of the essential inliers is a rival
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
    direct = [_with_direct_sigmas(keypoints, intrinsics, extrinsics, tracks, pair) for pair in confidence]
    through_model = _chained_sigmas(direct)
    result = []
    for pair in direct:
        updated = replace(pair, rotation_uncertainty_deg=through_model[(pair.first, pair.second)])
        reason = uncertain_reason(updated, pairs.get((pair.first, pair.second)))
        result.append(replace(updated, uncertain_reason=reason))
    return result


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


def _with_direct_sigmas(
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    extrinsics: dict[int, np.ndarray],
    tracks: list[dict[int, int]],
    pair: PairConfidence,
) -> PairConfidence:
    """The pair's own uncertainty, from the matches of its two views alone."""
    first, second = pair.first, pair.second
    shared = np.array(
        [(track[first], track[second]) for track in tracks if first in track and second in track],
        dtype=np.int64,
    ).reshape(-1, 2)
    rotation_sigma, direction_sigma = _pose_sigmas(
        keypoints[first][shared[:, 0]],
        keypoints[second][shared[:, 1]],
        intrinsics[first],
        intrinsics[second],
        extrinsics[first],
        extrinsics[second],
    )
    return replace(pair, rotation_uncertainty_deg=rotation_sigma, direction_uncertainty_deg=direction_sigma)


def uncertain_reason(pair: PairConfidence, geometry: TwoViewGeometry | None) -> str | None:
    """Why a pair's relative pose is not confident, naming the configuration; None when it is."""
    sigma, angle = pair.rotation_uncertainty_deg, pair.triangulation_angle_deg
    causes = []
    if geometry is not None and geometry.model == "essential":
        rivals = geometry.rivals
        if rivals.rotation_inliers >= RIVAL_SHARE * rivals.essential_inliers:
            causes.append("near-pure rotation: a turn in place explains the matches about as well")
        elif rivals.homography_inliers >= RIVAL_SHARE * rivals.essential_inliers:
            causes.append("near-planar: one homography explains the matches about as well")
    if math.isfinite(sigma) and math.isfinite(angle) and angle < MIN_ANGLE_OVER_SIGMA * sigma:
        causes.append(f"small triangulation angle ({angle:.1f} degrees against that uncertainty)")
    if not math.isfinite(sigma) or sigma > MAX_ROTATION_SIGMA_DEG or causes:
        uncertainty = f"+-{sigma:.1f} degrees" if math.isfinite(sigma) else "not measurable"
        return f"relative rotation uncertain ({uncertainty})" + "".join(f"; {cause}" for cause in causes)
    return None


def _pose_sigmas(
    first_pixels: np.ndarray,
    second_pixels: np.ndarray,
    first_intrinsic: np.ndarray,
    second_intrinsic: np.ndarray,
    first_extrinsic: np.ndarray,
    second_extrinsic: np.ndarray,
) -> tuple[float, float]:
    """Standard deviations (degrees) of the relative rotation and of the direction of travel."""
    rotation = second_extrinsic[:, :3] @ first_extrinsic[:, :3].T
    translation = second_extrinsic[:, 3] - rotation @ first_extrinsic[:, 3]
    length = np.linalg.norm(translation)
    if len(first_pixels) < MIN_SHARED or length < 1e-12:
        return math.nan, math.nan
    translation = translation / length
    n1 = normalized_coordinates(first_pixels, first_intrinsic)
    n2 = normalized_coordinates(second_pixels, second_intrinsic)
    focal = float(np.mean([first_intrinsic[0, 0], second_intrinsic[0, 0]]))
    across = np.linalg.svd(translation.reshape(1, 3))[2][1:]  # two unit vectors orthogonal to t

    def residuals(parameters: np.ndarray, keep: slice | np.ndarray = slice(None)) -> np.ndarray:
        turned = _exp(parameters[:3]) @ rotation
        moved = translation + parameters[3:] @ across
        return _sampson(n1[keep], n2[keep], turned, moved / np.linalg.norm(moved)) * focal

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


def _sampson(n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Signed Sampson distances of the matches to the essential matrix [t]x R (normalized units)."""
    essential = _cross(translation) @ rotation
    x1 = np.concatenate([n1, np.ones((len(n1), 1))], axis=1)
    x2 = np.concatenate([n2, np.ones((len(n2), 1))], axis=1)
    forward, backward = x1 @ essential.T, x2 @ essential
    numerator = np.sum(x2 * forward, axis=1)
    denominator = forward[:, 0] ** 2 + forward[:, 1] ** 2 + backward[:, 0] ** 2 + backward[:, 1] ** 2
    return numerator / np.sqrt(np.maximum(denominator, 1e-24))


def _cross(vector: np.ndarray) -> np.ndarray:
    x, y, z = vector
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _exp(rotation_vector: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(rotation_vector))
    if angle < 1e-15:
        return np.eye(3) + _cross(rotation_vector)
    axis = _cross(rotation_vector / angle)
    return np.eye(3) + math.sin(angle) * axis + (1 - math.cos(angle)) * axis @ axis
