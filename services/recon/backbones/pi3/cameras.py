"""From Pi3's outputs to our cameras: camera-from-world [R|t] (OpenCV axes) and pixel intrinsics.

Pi3 predicts camera-to-world poses and, per pixel, a point in its camera's frame; it has no
intrinsics output. The focal lengths follow from the points: a pixel at column u sees the
direction x/z = (u - cx) / fx. With the principal point at the image centre, fx (and fy) is the
weighted least-squares fit over the confident pixels.
"""

from __future__ import annotations

import numpy as np

MIN_PIXELS = 16  # fewer usable pixels than this: no focal length can be fitted


def extrinsics_from_poses(poses: np.ndarray) -> np.ndarray:
    """(N, 4, 4) camera-to-world -> (N, 3, 4) camera-from-world [R|t] (float64)."""
    poses = np.asarray(poses, dtype=np.float64)
    rotation_t = np.transpose(poses[:, :3, :3], (0, 2, 1))
    translation = -np.einsum("nij,nj->ni", rotation_t, poses[:, :3, 3])
    return np.concatenate((rotation_t, translation[:, :, None]), axis=2)


def fit_focal(
    local_points: np.ndarray, weights: np.ndarray
) -> tuple[tuple[float, float], tuple[float, float]]:
    """(H, W, 3) camera-frame points, (H, W) weights -> ((fx, fy), (cx, cy)) in those pixels.

    Returns NaN focal lengths when too few pixels have a positive depth and weight, or when the
    fit is not positive.
    """
    height, width = local_points.shape[:2]
    centre = ((width - 1) / 2.0, (height - 1) / 2.0)
    z = local_points[..., 2].astype(np.float64)
    usable = np.isfinite(local_points).all(axis=-1) & (z > 0) & (weights > 0)
    if usable.sum() < MIN_PIXELS:
        return (float("nan"), float("nan")), centre
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    w = weights[usable].astype(np.float64)
    focals = []
    for offset, direction in ((u - centre[0], local_points[..., 0]), (v - centre[1], local_points[..., 1])):
        ratio = direction[usable] / z[usable]
        denominator = float(np.sum(w * ratio * ratio))
        focals.append(
            float(np.sum(w * offset[usable] * ratio)) / denominator if denominator > 0 else float("nan")
        )
    # A focal length that is not positive is no camera (the points do not form a pinhole image).
    focals = [f if np.isfinite(f) and f > 0 else float("nan") for f in focals]
    return (focals[0], focals[1]), centre
