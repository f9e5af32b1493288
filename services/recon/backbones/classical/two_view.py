"""Relative pose of two views from their matches: essential matrix or pure rotation.

Both models are fitted with RANSAC. Photos for spatial questions often turn in place; then the
essential matrix is degenerate (any translation fits) and its pose is noise. So a rotation-only
model is fitted too (homography on normalized coordinates, R = K^-1 H K made orthonormal, then
refined on the inlier rays). When the rotation explains nearly every match the essential matrix
explains, the pair has no usable parallax and is reported as a pure rotation with zero
translation.

The homography's RANSAC fit does not depend on the intrinsics (see HomographyFit), so a rebuild
of the pairs at another focal (self-calibration) passes the first fits back in and re-runs only
what the focal changes: the essential matrix and the rotation's refinement on the rays.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from .geometry import bearings, normalized_coordinates, rotation_between_bearings

MIN_INLIERS = 15  # fewer inliers than this cannot tell a real pose from chance agreement
ESSENTIAL_THRESHOLD_PX = 1.0  # epipolar distance, pixels
ROTATION_THRESHOLD_PX = 2.0  # point transfer error of the rotation model, pixels
ROTATION_SHARE = 0.9  # rotation must explain this share of the essential inliers


@dataclass(frozen=True)
class Rivals:
    """How well each candidate model explained the pair's matches: verification and uncertainty
    weigh the chosen model against the others (two models explaining the matches about equally
    well leave the pose ambiguous)."""

    essential_inliers: int = 0  # epipolar inliers that also triangulate in front of both views
    epipolar_inliers: int = 0  # epipolar inliers of the essential matrix, before that check
    rotation_inliers: int = 0
    homography_inliers: int = 0  # a general homography: a plane seen from two places, or a turn
    essential_rotation: np.ndarray | None = None  # the essential model's rotation, when fitted
    essential_parallax_deg: float = 0.0  # its median ray angle once its rotation is removed
    turn: np.ndarray | None = None  # the rotation-only model's rotation, when fitted
    homography: np.ndarray | None = None  # the general homography, normalized coordinates


@dataclass(frozen=True)
class HomographyFit:
    """A pair's RANSAC homography in pixels (first view -> second) and its inlier mask per match.

    The same at any focal: normalizing pixels with a pinhole K (fx = fy) only shifts and scales
    them, the threshold scales with the focal (it is ROTATION_THRESHOLD_PX in pixels), and the
    fit normalizes its points itself, so the same matches give the same inliers (all 138 pairs of
    the tuning rings and templeRing subsets, fitted at the prior and at 1420 px)."""

    pixels: np.ndarray | None  # None: no homography fits the matches
    inliers: np.ndarray  # (M,) bool

    def normalized(self, first_intrinsic: np.ndarray, second_intrinsic: np.ndarray) -> np.ndarray:
        """The homography between the two views' normalized coordinates, scaled to H[2, 2] = 1."""
        assert self.pixels is not None
        homography = np.linalg.inv(second_intrinsic) @ self.pixels @ first_intrinsic
        return homography / homography[2, 2] if abs(homography[2, 2]) > 1e-12 else homography


def fit_homography(
    first_pixels: np.ndarray,
    second_pixels: np.ndarray,
    first_intrinsic: np.ndarray,
    second_intrinsic: np.ndarray,
    matches: np.ndarray,
) -> HomographyFit:
    """RANSAC homography of the matches (fitted on normalized coordinates, returned in pixels)."""
    n1 = normalized_coordinates(first_pixels[matches[:, 0]], first_intrinsic)
    n2 = normalized_coordinates(second_pixels[matches[:, 1]], second_intrinsic)
    focal = float(second_intrinsic[0, 0])
    homography, mask = cv2.findHomography(n1, n2, cv2.RANSAC, ROTATION_THRESHOLD_PX / focal, maxIters=4000)
    if homography is None or mask is None:
        return HomographyFit(None, np.zeros(len(matches), dtype=bool))
    return HomographyFit(second_intrinsic @ homography @ np.linalg.inv(first_intrinsic), mask.ravel() > 0)


@dataclass(frozen=True)
class TwoViewGeometry:
    """x_second = rotation @ x_first + translation (camera axes); translation is unit or zero."""

    matches: np.ndarray  # (M, 2) inlier keypoint index pairs (first view, second view)
    rotation: np.ndarray
    translation: np.ndarray
    model: str  # "essential" or "rotation"
    median_parallax_deg: float  # angle between the rays of a match after removing the rotation
    rivals: Rivals = field(default_factory=Rivals)
    # Every match the pose was fitted to (inliers or not): other basins of the pose are searched
    # on these (pose_basins), since a pose in the wrong basin keeps only the matches that fit it.
    candidates: np.ndarray | None = None

    @property
    def is_rotation(self) -> bool:
        return self.model == "rotation"


def estimate_two_view(
    first_pixels: np.ndarray,
    second_pixels: np.ndarray,
    first_intrinsic: np.ndarray,
    second_intrinsic: np.ndarray,
    matches: np.ndarray,
    homography: HomographyFit | None = None,
) -> TwoViewGeometry | None:
    """Pose of the second camera relative to the first, or None when the matches do not agree.

    `homography`: the matches' fit_homography when already fitted (at any focal), else fitted here."""
    if len(matches) < MIN_INLIERS:
        return None
    p1, p2 = first_pixels[matches[:, 0]], second_pixels[matches[:, 1]]
    n1, n2 = normalized_coordinates(p1, first_intrinsic), normalized_coordinates(p2, second_intrinsic)
    focal = float(np.mean([first_intrinsic[0, 0], second_intrinsic[0, 0]]))

    essential = _fit_essential(n1, n2, ESSENTIAL_THRESHOLD_PX / focal)
    if homography is None:
        homography = fit_homography(first_pixels, second_pixels, first_intrinsic, second_intrinsic, matches)
    rotation_fit = _fit_rotation(
        homography, n1, first_pixels, second_pixels, matches, first_intrinsic, second_intrinsic
    )
    essential_count = 0 if essential is None else int(essential[2].sum())
    rotation_count = 0 if rotation_fit is None else int(rotation_fit[1].sum())
    if max(essential_count, rotation_count) < MIN_INLIERS:
        return None

    rivals = Rivals(
        essential_count,
        0 if essential is None else int(essential[3]),
        rotation_count,
        0 if rotation_fit is None else int(rotation_fit[2]),
        None if essential is None else essential[0],
        0.0 if essential is None else _median_parallax_deg(n1[essential[2]], n2[essential[2]], essential[0]),
        None if rotation_fit is None else rotation_fit[0],
        None if rotation_fit is None else rotation_fit[3],
    )
    if rotation_fit is not None and rotation_count >= ROTATION_SHARE * essential_count:
        rotation, inliers, _, _ = rotation_fit
        parallax = _median_parallax_deg(n1[inliers], n2[inliers], rotation)
        return TwoViewGeometry(matches[inliers], rotation, np.zeros(3), "rotation", parallax, rivals, matches)
    assert essential is not None
    rotation, translation, inliers, _ = essential
    return TwoViewGeometry(
        matches[inliers], rotation, translation, "essential", rivals.essential_parallax_deg, rivals, matches
    )


def _fit_essential(
    n1: np.ndarray, n2: np.ndarray, threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int] | None:
    """Rotation, unit translation, inliers in front of both views, and the epipolar inlier count."""
    if len(n1) < 5:
        return None
    identity = np.eye(3)
    # MAGSAC++ polishes the model on its inliers: several times more accurate than plain RANSAC.
    essential, mask = cv2.findEssentialMat(
        n1, n2, identity, method=cv2.USAC_MAGSAC, prob=0.9999, threshold=threshold
    )
    if essential is None or mask is None:
        return None
    if essential.shape != (3, 3):  # several solutions stacked: keep the first (best scored)
        essential = essential[:3]
    _, rotation, translation, pose_mask = cv2.recoverPose(essential, n1, n2, identity, mask=mask.copy())
    inliers = (pose_mask.ravel() > 0) & (mask.ravel() > 0)
    translation = translation.ravel()
    return rotation, translation / max(np.linalg.norm(translation), 1e-12), inliers, int((mask > 0).sum())


def _fit_rotation(
    fit: HomographyFit,
    n1: np.ndarray,
    first_pixels: np.ndarray,
    second_pixels: np.ndarray,
    matches: np.ndarray,
    first_intrinsic: np.ndarray,
    second_intrinsic: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, int, np.ndarray] | None:
    """Rotation-only model: the RANSAC homography `fit`, made a rotation.

    Also returns how many matches the general homography itself explains, and that homography
    (normalized coordinates)."""
    if fit.pixels is None:
        return None
    homography = fit.normalized(first_intrinsic, second_intrinsic)
    determinant = np.linalg.det(homography)
    if abs(determinant) < 1e-12:
        return None
    rays1 = bearings(first_pixels[matches[:, 0]], first_intrinsic)
    rays2 = bearings(second_pixels[matches[:, 1]], second_intrinsic)
    # The nearest rotation to a noisy homography can be a degree off, pixels beyond the
    # threshold everywhere: fit the rotation to the rays the homography explains instead.
    inliers = fit.inliers
    rotation = np.eye(3)
    for _ in range(3):  # fit on the rays taken as inliers, then re-select them
        if inliers.sum() < 3:
            return None
        rotation = rotation_between_bearings(rays1[inliers], rays2[inliers])
        inliers = _rotation_inliers(rotation, n1, second_pixels[matches[:, 1]], second_intrinsic)
    return rotation, inliers, int(fit.inliers.sum()), homography


def _rotation_inliers(
    rotation: np.ndarray, n1: np.ndarray, p2: np.ndarray, second_intrinsic: np.ndarray
) -> np.ndarray:
    rays = np.concatenate([n1, np.ones((len(n1), 1))], axis=1) @ rotation.T
    ahead = rays[:, 2] > 1e-6
    safe_z = np.where(ahead, rays[:, 2], 1.0)
    predicted = rays[:, :2] / safe_z[:, None] * np.array([second_intrinsic[0, 0], second_intrinsic[1, 1]])
    predicted += np.array([second_intrinsic[0, 2], second_intrinsic[1, 2]])
    error = np.linalg.norm(predicted - p2, axis=1)
    return ahead & (error < ROTATION_THRESHOLD_PX)


def _median_parallax_deg(n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray) -> float:
    if len(n1) == 0:
        return 0.0
    rays1 = np.concatenate([n1, np.ones((len(n1), 1))], axis=1) @ rotation.T
    rays2 = np.concatenate([n2, np.ones((len(n2), 1))], axis=1)
    rays1 /= np.linalg.norm(rays1, axis=1, keepdims=True)
    rays2 /= np.linalg.norm(rays2, axis=1, keepdims=True)
    cosine = np.clip(np.sum(rays1 * rays2, axis=1), -1.0, 1.0)
    return float(np.degrees(np.median(np.arccos(cosine))))
