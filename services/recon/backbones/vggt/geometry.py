"""Decode VGGT's pose encoding into cameras and lift depth maps to world points.

Cameras follow docs/ARCHITECTURE.md: 3x4 camera-from-world extrinsics in OpenCV axes, 3x3
intrinsics in pixels with pixel (u, v) at its integer index.
"""

from __future__ import annotations

import numpy as np
import torch


def quaternion_to_rotation(quaternion: torch.Tensor) -> torch.Tensor:
    """(..., 4) scalar-last xyzw quaternions, not necessarily unit -> (..., 3, 3) rotations.

    Dividing by the squared norm makes any non-zero quaternion give a proper rotation.
    """
    x, y, z, w = quaternion.unbind(-1)
    s = 2.0 / (quaternion * quaternion).sum(-1)
    rows = (
        1 - s * (y * y + z * z),
        s * (x * y - z * w),
        s * (x * z + y * w),
        s * (x * y + z * w),
        1 - s * (x * x + z * z),
        s * (y * z - x * w),
        s * (x * z - y * w),
        s * (y * z + x * w),
        1 - s * (x * x + y * y),
    )
    return torch.stack(rows, dim=-1).reshape(*quaternion.shape[:-1], 3, 3)


def pose_encoding_to_cameras(
    pose_encoding: torch.Tensor, image_size_hw: tuple[int, int]
) -> tuple[torch.Tensor, torch.Tensor]:
    """(..., 9) encodings of images of (height, width) -> extrinsics (..., 3, 4), intrinsics (..., 3, 3).

    Encoding: translation xyz, quaternion xyzw, field of view vertical then horizontal (radians).
    The principal point is the image centre and focal lengths follow from the fields of view.
    """
    height, width = image_size_hw
    translation = pose_encoding[..., :3]
    rotation = quaternion_to_rotation(pose_encoding[..., 3:7])
    extrinsics = torch.cat((rotation, translation[..., None]), dim=-1)
    fy = (height / 2.0) / torch.tan(pose_encoding[..., 7] / 2.0)
    fx = (width / 2.0) / torch.tan(pose_encoding[..., 8] / 2.0)
    intrinsics = torch.zeros(*pose_encoding.shape[:-1], 3, 3, dtype=pose_encoding.dtype, device=fx.device)
    intrinsics[..., 0, 0] = fx
    intrinsics[..., 1, 1] = fy
    intrinsics[..., 0, 2] = width / 2.0
    intrinsics[..., 1, 2] = height / 2.0
    intrinsics[..., 2, 2] = 1.0
    return extrinsics, intrinsics


def depth_to_camera_points(depth: np.ndarray, intrinsic: np.ndarray) -> np.ndarray:
    """(H, W) z-depth -> (H, W, 3) points in camera coordinates (float64)."""
    height, width = depth.shape
    u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    z = depth.astype(np.float64)
    x = (u - intrinsic[0, 2]) * z / intrinsic[0, 0]
    y = (v - intrinsic[1, 2]) * z / intrinsic[1, 1]
    return np.stack((x, y, z), axis=-1)


def camera_to_world(points: np.ndarray, extrinsic: np.ndarray) -> np.ndarray:
    """Apply the inverse of a camera-from-world [R|t] to (..., 3) camera points."""
    rotation = np.asarray(extrinsic[:3, :3], dtype=np.float64)
    translation = np.asarray(extrinsic[:3, 3], dtype=np.float64)
    return (points - translation) @ rotation  # R^T (x - t), written for row vectors


def unproject_depth_maps(depths: np.ndarray, extrinsics: np.ndarray, intrinsics: np.ndarray) -> np.ndarray:
    """(S, H, W) or (S, H, W, 1) depths with per-view cameras -> (S, H, W, 3) world points (float64)."""
    depths = np.asarray(depths)
    if depths.ndim == 4:
        depths = depths[..., 0]
    return np.stack(
        [
            camera_to_world(depth_to_camera_points(depth, np.asarray(k, np.float64)), e)
            for depth, e, k in zip(depths, extrinsics, intrinsics, strict=True)
        ]
    )
