"""Posed RGB-D views to a coloured world point cloud (a `Reconstruction`).

Depth is z-depth; a depth map may be smaller than its image, in which case its pixel grid spans the
whole image and the intrinsics scale by (w / width, h / height) (docs/ARCHITECTURE.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from shared.geometry.poses import validate_extrinsic
from shared.geometry.reconstruction import Reconstruction


def scale_intrinsic(intrinsic: np.ndarray, scale_x: float, scale_y: float) -> np.ndarray:
    """Intrinsics of the same camera on a grid resized by (scale_x, scale_y)."""
    scaled = np.array(intrinsic, dtype=np.float64)
    scaled[0] *= scale_x
    scaled[1] *= scale_y
    return scaled


def _check_depth(depth: np.ndarray) -> np.ndarray:
    depth_map = np.asarray(depth, dtype=np.float32)
    if depth_map.ndim != 2 or depth_map.size == 0:
        raise ValueError(f"depth must be a non-empty (h, w) array, got shape {depth_map.shape}")
    return depth_map


def _check_intrinsic(intrinsic: np.ndarray) -> np.ndarray:
    matrix = np.asarray(intrinsic, dtype=np.float64)
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)) or matrix[0, 0] <= 0 or matrix[1, 1] <= 0:
        raise ValueError(f"intrinsic must be a finite 3x3 with positive focals, got {matrix.tolist()}")
    return matrix


def _backproject(
    depth_map: np.ndarray, intrinsic: np.ndarray, extrinsic: np.ndarray, stride: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points of valid depth pixels on the strided grid, with their (row, column) indices."""
    rows, columns = np.mgrid[0 : depth_map.shape[0] : stride, 0 : depth_map.shape[1] : stride]
    sampled = depth_map[rows, columns]
    valid = np.isfinite(sampled) & (sampled > 0)
    rows, columns, z = rows[valid], columns[valid], sampled[valid].astype(np.float64)
    x = (columns - intrinsic[0, 2]) / intrinsic[0, 0] * z
    y = (rows - intrinsic[1, 2]) / intrinsic[1, 1] * z
    in_camera = np.stack([x, y, z], axis=1)
    rotation, translation = extrinsic[:3, :3], extrinsic[:3, 3]
    # x_cam = R x_world + t  =>  x_world = R^T (x_cam - t)
    return (in_camera - translation) @ rotation, rows, columns


def backproject_depth(
    depth: np.ndarray, intrinsic: np.ndarray, extrinsic: np.ndarray, stride: int = 1
) -> np.ndarray:
    """(N, 3) float64 world points of the valid (finite, > 0) depths; `intrinsic` is on the depth grid."""
    if stride < 1:
        raise ValueError(f"stride must be >= 1, got {stride}")
    points, _, _ = _backproject(
        _check_depth(depth), _check_intrinsic(intrinsic), validate_extrinsic(extrinsic), stride
    )
    return points


@dataclass
class _PosedRGBDView:
    """One view's contribution to the fused cloud, checked and back-projected."""

    points: np.ndarray  # (N, 3) world
    colors: np.ndarray  # (N, 3) uint8
    pose: np.ndarray  # 3x4 camera-from-world
    intrinsic: np.ndarray  # 3x3, image pixels
    size: tuple[int, int]  # (width, height) of the image
    depth_map: np.ndarray


def _fuse_view(
    view: int, image: np.ndarray, depth: np.ndarray, extrinsic: np.ndarray, intrinsic: np.ndarray, stride: int
) -> _PosedRGBDView:
    """Check one posed RGB-D view and back-project it, each point coloured by the pixel under it."""
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError(f"image {view + 1} must be uint8 (H, W, 3), got {image.dtype} {image.shape}")
    depth_map = _check_depth(depth)
    height, width = image.shape[:2]
    if depth_map.shape[0] > height or depth_map.shape[1] > width:
        raise ValueError(f"depth {view + 1} {depth_map.shape} is larger than its image {image.shape[:2]}")
    pose = validate_extrinsic(extrinsic)[:3]
    intrinsic = _check_intrinsic(intrinsic)
    scale_x, scale_y = depth_map.shape[1] / width, depth_map.shape[0] / height
    points, rows, columns = _backproject(
        depth_map, scale_intrinsic(intrinsic, scale_x, scale_y), pose, stride
    )
    # Image pixel under each depth sample: the grids share their extent, so index scales.
    image_rows = np.minimum((rows * (height / depth_map.shape[0])).astype(np.int64), height - 1)
    image_columns = np.minimum((columns * (width / depth_map.shape[1])).astype(np.int64), width - 1)
    colors = image[image_rows, image_columns]
    return _PosedRGBDView(points, colors, pose, intrinsic, (width, height), depth_map)


def reconstruction_from_rgbd(
    images: Sequence[np.ndarray],
    depths: Sequence[np.ndarray],
    extrinsics: np.ndarray | Sequence[np.ndarray],
    intrinsics: np.ndarray | Sequence[np.ndarray],
    stride: int = 1,
    backbone: str = "posed-rgbd",
    version: str = "1",
) -> Reconstruction:
    """Fuse posed RGB-D views into one coloured cloud; intrinsics are in image pixels.

    Extrinsics are 3x4 (or 4x4) camera-from-world [R|t] with OpenCV axes (x right, y down, z
    forward). Colours come from the image pixel under each depth sample (nearest, via the grid
    scaling).
    """
    views = len(images)
    if views == 0:
        raise ValueError("at least one view is needed")
    for name, values in (("depths", depths), ("extrinsics", extrinsics), ("intrinsics", intrinsics)):
        if len(values) != views:
            raise ValueError(f"{views} images but {len(values)} {name}")
    if stride < 1:
        raise ValueError(f"stride must be >= 1, got {stride}")
    fused = [
        _fuse_view(view, images[view], depths[view], extrinsics[view], intrinsics[view], stride)
        for view in range(views)
    ]
    return Reconstruction(
        points=np.concatenate([view.points for view in fused]).astype(np.float32),
        colors=np.concatenate([view.colors for view in fused]),
        extrinsics=np.stack([view.pose for view in fused]),
        intrinsics=np.stack([view.intrinsic for view in fused]),
        image_sizes=np.array([view.size for view in fused]),
        registered=np.ones(views, dtype=bool),
        backbone=backbone,
        backbone_version=version,
        depths=[view.depth_map for view in fused],
        warnings=[
            f"view {v + 1} has no valid depth" for v, view in enumerate(fused) if len(view.points) == 0
        ],
        intrinsics_source=["given"] * views,
    )


__all__ = ["backproject_depth", "reconstruction_from_rgbd", "scale_intrinsic"]
