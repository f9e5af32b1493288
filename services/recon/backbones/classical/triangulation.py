"""Triangulation of matched pixels into 3D points, with the checks that keep only sound ones.

A point is kept when it lies in front of every camera that sees it, reprojects within a few
pixels in each, and its rays meet at a useful angle (nearly parallel rays give depth that is
mostly noise).
"""

from __future__ import annotations

import cv2
import numpy as np

from .geometry import camera_center, project

MAX_REPROJECTION_PX = 2.5
MIN_RAY_ANGLE_DEG = 1.0


def projection_matrix(extrinsic: np.ndarray, intrinsic: np.ndarray) -> np.ndarray:
    return intrinsic @ extrinsic


def triangulate_pair(
    first_extrinsic: np.ndarray,
    second_extrinsic: np.ndarray,
    first_intrinsic: np.ndarray,
    second_intrinsic: np.ndarray,
    first_pixels: np.ndarray,
    second_pixels: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """World points (N, 3) and a mask of the ones that pass every check."""
    if len(first_pixels) == 0:
        return np.zeros((0, 3)), np.zeros(0, dtype=bool)
    homogeneous = cv2.triangulatePoints(
        projection_matrix(first_extrinsic, first_intrinsic),
        projection_matrix(second_extrinsic, second_intrinsic),
        first_pixels.T.astype(np.float64),
        second_pixels.T.astype(np.float64),
    )
    w = homogeneous[3]
    finite = np.abs(w) > 1e-12
    points = (homogeneous[:3] / np.where(finite, w, 1.0)).T
    keep = finite & points_are_sound(
        points,
        [first_extrinsic, second_extrinsic],
        [first_intrinsic, second_intrinsic],
        [first_pixels, second_pixels],
    )
    return points, keep


def points_are_sound(
    points: np.ndarray,
    extrinsics: list[np.ndarray],
    intrinsics: list[np.ndarray],
    pixels: list[np.ndarray],
    max_error_px: float = MAX_REPROJECTION_PX,
) -> np.ndarray:
    """Cheirality, reprojection error and ray angle, for points each seen in all given views."""
    keep = np.all(np.isfinite(points), axis=1)
    for extrinsic, intrinsic, observed in zip(extrinsics, intrinsics, pixels, strict=True):
        predicted, depth = project(points, extrinsic, intrinsic)
        keep &= depth > 1e-9
        keep &= np.linalg.norm(predicted - observed, axis=1) < max_error_px
    return keep & (max_ray_angle_deg(points, extrinsics) >= MIN_RAY_ANGLE_DEG)


def max_ray_angle_deg(points: np.ndarray, extrinsics: list[np.ndarray]) -> np.ndarray:
    """Largest angle, per point, between the rays from the given camera centres."""
    rays = []
    for extrinsic in extrinsics:
        ray = points - camera_center(extrinsic)
        rays.append(ray / np.maximum(np.linalg.norm(ray, axis=1, keepdims=True), 1e-12))
    widest = np.zeros(len(points))
    for a in range(len(rays)):
        for b in range(a + 1, len(rays)):
            cosine = np.clip(np.sum(rays[a] * rays[b], axis=1), -1.0, 1.0)
            widest = np.maximum(widest, np.degrees(np.arccos(cosine)))
    return widest


def stacked_observations(
    tracks: list[dict[int, int]],
    views: list[int],
    keypoints: list[np.ndarray],
    matrices: dict[int, np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tracks' observations in `views` as triangulate_many_views takes them: projections
    (N, K, 3, 4) from `matrices` (view -> 3x4), pixels (N, K, 2) and seen (N, K), with K the views
    in the given order. One fancy-indexed copy per view, not one per observation."""
    count = len(tracks)
    projections = np.zeros((count, len(views), 3, 4))
    pixels = np.zeros((count, len(views), 2))
    seen = np.zeros((count, len(views)), dtype=bool)
    for slot, view in enumerate(views):
        observing = [(point, track[view]) for point, track in enumerate(tracks) if view in track]
        if not observing:
            continue
        rows, indices = np.array(observing, dtype=np.int64).T
        projections[rows, slot] = matrices[view]
        pixels[rows, slot] = keypoints[view][indices]
        seen[rows, slot] = True
    return projections, pixels, seen


def triangulate_many_views(projections: np.ndarray, pixels: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """Linear (DLT) triangulation of N points, each from up to K views, in one batched SVD.

    projections (N, K, 3, 4), pixels (N, K, 2), seen (N, K) bool. Rows of unseen views are zero
    and so do not constrain the solution.
    """
    rows_u = pixels[..., 0:1] * projections[..., 2, :] - projections[..., 0, :]
    rows_v = pixels[..., 1:2] * projections[..., 2, :] - projections[..., 1, :]
    system = np.concatenate([rows_u, rows_v], axis=1) * np.concatenate([seen, seen], axis=1)[..., None]
    # Balance each point's rows so a far point's tiny numbers do not lose to rounding.
    scale = np.maximum(np.linalg.norm(system, axis=2, keepdims=True), 1e-12)
    balanced = system / scale
    # The null vector is the eigenvector of the smallest eigenvalue of the 4x4 normal matrix: the
    # same solution as the SVD's last right singular vector, at under half the cost.
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", balanced, balanced))
    homogeneous = vectors[:, :, 0]
    w = homogeneous[:, 3:4]
    return homogeneous[:, :3] / np.where(np.abs(w) > 1e-12, w, np.nan)
