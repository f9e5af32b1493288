"""A denser coloured cloud from the sparse model: interpolated depth, verified across views.

Why this method: rectified stereo (StereoSGBM) breaks down on the wide, rotating baselines of a
few photos walked around a room, and dense matching needs far more compute than two shared CPU
cores. Instead, each view's triangulated keypoints are connected by a Delaunay triangulation in
the image, and inverse depth is interpolated linearly inside each triangle (exact for a planar
patch, which walls, floors, tables and box faces are). Triangles that span long distances or
jump in depth are dropped. Every interpolated point must then agree, within a few percent, with
the depth another view interpolated for the same place; surfaces that one view invents across a
depth discontinuity do not survive that check.

Depth maps live on a grid of (width // step, height // step) cells spanning the original image,
following the project's depth-map convention.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .geometry import project

GRID_STEP = 4  # depth-map cell, in working-image pixels
MAX_EDGE_SHARE = 0.15  # longest triangle edge, as a share of the longer image side
MAX_DEPTH_RATIO = 1.6  # deepest / shallowest vertex of one triangle
CONSISTENCY = 0.04  # relative depth agreement needed with another view


@dataclass(frozen=True)
class ViewSamples:
    """What one registered view contributes: its sparse depth samples and its working image."""

    view: int
    extrinsic: np.ndarray  # 3x4 camera-from-world
    intrinsic: np.ndarray  # working-image pixels
    image: np.ndarray  # working image, uint8 RGB
    original_size: tuple[int, int]  # (width, height)
    scale: float  # working / original
    pixels: np.ndarray  # (S, 2) working pixels of triangulated keypoints
    depths: np.ndarray  # (S,) their z-depths


@dataclass(frozen=True)
class DenseResult:
    points: np.ndarray  # (N, 3)
    colors: np.ndarray  # (N, 3) uint8
    depth_maps: dict[int, np.ndarray]  # view -> verified z-depth grid, 0 = unknown
    support: np.ndarray  # (N,) views that agree on each point: its own and the confirming ones


def grid_size(original_size: tuple[int, int], scale: float) -> tuple[int, int]:
    width, height = original_size
    return max(1, round(width * scale / GRID_STEP)), max(1, round(height * scale / GRID_STEP))


def grid_to_working(samples: ViewSamples) -> np.ndarray:
    """Affine map from grid cells to working pixels: cell j covers original u = j * width / w."""
    grid_w, grid_h = grid_size(samples.original_size, samples.scale)
    width, height = samples.original_size
    step_u, step_v = width / grid_w * samples.scale, height / grid_h * samples.scale
    offset = 0.5 * samples.scale - 0.5
    return np.array([[step_u, 0.0, offset], [0.0, step_v, offset], [0.0, 0.0, 1.0]])


def interpolate_depth(samples: ViewSamples) -> np.ndarray:
    """(h, w) z-depth grid from the view's sparse samples; 0 outside accepted triangles."""
    grid_w, grid_h = grid_size(samples.original_size, samples.scale)
    depth = np.zeros((grid_h, grid_w), dtype=np.float32)
    if len(samples.pixels) < 3:
        return depth
    to_grid = np.linalg.inv(grid_to_working(samples))
    vertices = samples.pixels @ to_grid[:2, :2].T + to_grid[:2, 2]
    triangles = _delaunay(vertices, grid_w, grid_h)
    if len(triangles) == 0:
        return depth
    corners, inverse_depths = vertices[triangles], 1.0 / samples.depths[triangles]
    working_corners = samples.pixels[triangles]
    edges = np.linalg.norm(working_corners - np.roll(working_corners, 1, axis=1), axis=2).max(axis=1)
    ratio = inverse_depths.max(axis=1) / inverse_depths.min(axis=1)
    working_side = max(samples.image.shape[:2])
    accepted = (edges < MAX_EDGE_SHARE * working_side) & (ratio < MAX_DEPTH_RATIO)
    owner = np.full((grid_h, grid_w), -1, dtype=np.int32)
    fixed_point = np.round(corners * 16).astype(np.int32)  # 4 fractional bits (shift=4)
    for index in np.flatnonzero(accepted).tolist():  # in order: a later triangle paints over
        cv2.fillConvexPoly(owner, fixed_point[index], index, shift=4)
    rows, cols = np.nonzero(owner >= 0)
    ids = owner[rows, cols]
    weights = _barycentric(corners[ids], np.stack([cols, rows], axis=1).astype(np.float64))
    inverse = np.sum(weights * inverse_depths[ids], axis=1)
    valid = inverse > 0
    depth[rows[valid], cols[valid]] = 1.0 / inverse[valid]
    return depth


def _delaunay(vertices: np.ndarray, grid_w: int, grid_h: int) -> np.ndarray:
    """(T, 3) vertex indices of the Delaunay triangles of points inside the grid."""
    inside = (
        (vertices[:, 0] >= 0) & (vertices[:, 1] >= 0) & (vertices[:, 0] < grid_w) & (vertices[:, 1] < grid_h)
    )
    subdivision = cv2.Subdiv2D((0, 0, grid_w, grid_h))
    lookup: dict[tuple[float, float], int] = {}
    # Subdiv2D keeps float32 positions: keys are the float32 values (tolist gives them exactly).
    inside_indices = np.flatnonzero(inside)
    keys = vertices[inside_indices].astype(np.float32).tolist()
    for index, key in zip(inside_indices.tolist(), keys, strict=True):
        key = tuple(key)
        if key not in lookup:
            lookup[key] = index
            subdivision.insert(key)
    triangles = []
    corners = np.asarray(subdivision.getTriangleList(), dtype=np.float32).reshape(-1, 3, 2).tolist()
    for triangle in corners:
        corner_ids = [lookup.get(tuple(corner)) for corner in triangle]
        if None not in corner_ids:  # triangles touching Subdiv2D's outer helper vertices are skipped
            triangles.append(corner_ids)
    return np.array(triangles, dtype=np.int64).reshape(-1, 3)


def _barycentric(corners: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, 3) barycentric weights of points in their triangles (N, 3, 2)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    v0, v1, v2 = b - a, c - a, points - a
    denominator = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    denominator = np.where(np.abs(denominator) < 1e-12, 1e-12, denominator)
    w1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / denominator
    w2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / denominator
    weights = np.stack([1.0 - w1 - w2, w1, w2], axis=1)
    return np.clip(weights, 0.0, 1.0) / np.clip(weights, 0.0, 1.0).sum(axis=1, keepdims=True).clip(1e-12)


def densify(views: list[ViewSamples]) -> DenseResult:
    """Interpolate each view's depth, keep what another view confirms, lift it to coloured points."""
    depth_maps = {samples.view: interpolate_depth(samples) for samples in views}
    all_points, all_colors, all_support, verified_maps = [], [], [], {}
    for samples in views:
        depth = depth_maps[samples.view]
        points, grid_rows, grid_cols = _lift(samples, depth)
        agreeing = np.zeros(len(points), dtype=np.int32)
        for other in views:
            if other.view != samples.view:
                agreeing += _agrees_with(points, other, depth_maps[other.view])
        confirmed = agreeing > 0
        verified = np.zeros_like(depth)
        verified[grid_rows[confirmed], grid_cols[confirmed]] = depth[
            grid_rows[confirmed], grid_cols[confirmed]
        ]
        verified_maps[samples.view] = verified
        working = _grid_pixels(samples, grid_rows[confirmed], grid_cols[confirmed])
        all_points.append(points[confirmed])
        all_colors.append(_sample_colors(samples.image, working))
        all_support.append(1 + agreeing[confirmed])
    if not all_points:
        return DenseResult(np.zeros((0, 3)), np.zeros((0, 3), np.uint8), verified_maps, np.zeros(0))
    return DenseResult(
        np.concatenate(all_points), np.concatenate(all_colors), verified_maps, np.concatenate(all_support)
    )


def _grid_pixels(samples: ViewSamples, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    to_working = grid_to_working(samples)
    grid = np.stack([cols, rows], axis=1).astype(np.float64)
    return grid @ to_working[:2, :2].T + to_working[:2, 2]


def _lift(samples: ViewSamples, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rows, cols = np.nonzero(depth > 0)
    pixels = _grid_pixels(samples, rows, cols)
    intrinsic = samples.intrinsic
    z = depth[rows, cols].astype(np.float64)
    camera = np.stack(
        [
            (pixels[:, 0] - intrinsic[0, 2]) / intrinsic[0, 0] * z,
            (pixels[:, 1] - intrinsic[1, 2]) / intrinsic[1, 1] * z,
            z,
        ],
        axis=1,
    )
    rotation, translation = samples.extrinsic[:, :3], samples.extrinsic[:, 3]
    return (camera - translation) @ rotation, rows, cols


def _agrees_with(points: np.ndarray, other: ViewSamples, other_depth: np.ndarray) -> np.ndarray:
    """Points whose depth in `other` matches the depth `other` interpolated at that place."""
    pixels, z = project(points, other.extrinsic, other.intrinsic)
    to_grid = np.linalg.inv(grid_to_working(other))
    grid = np.round(pixels @ to_grid[:2, :2].T + to_grid[:2, 2]).astype(np.int64)
    height, width = other_depth.shape
    inside = (z > 0) & (grid[:, 0] >= 0) & (grid[:, 1] >= 0) & (grid[:, 0] < width) & (grid[:, 1] < height)
    reference = np.zeros(len(points))
    reference[inside] = other_depth[grid[inside, 1], grid[inside, 0]]
    return inside & (reference > 0) & (np.abs(z - reference) < CONSISTENCY * np.maximum(reference, 1e-12))


def _sample_colors(image: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    height, width = image.shape[:2]
    cols = np.clip(np.round(pixels[:, 0]).astype(np.int64), 0, width - 1)
    rows = np.clip(np.round(pixels[:, 1]).astype(np.int64), 0, height - 1)
    return image[rows, cols]


def unit_sphere_cloud(views: list[ViewSamples]) -> tuple[np.ndarray, np.ndarray]:
    """For views that only rotate about one centre: each grid pixel's colour at ray length 1.

    Depth is undefined without a baseline, but directions are exact, so novel *rotated* views of
    this cloud are still right.
    """
    all_points, all_colors = [], []
    for samples in views:
        grid_w, grid_h = grid_size(samples.original_size, samples.scale)
        rows, cols = np.mgrid[0:grid_h, 0:grid_w]
        pixels = _grid_pixels(samples, rows.ravel(), cols.ravel())
        intrinsic = samples.intrinsic
        rays = np.stack(
            [
                (pixels[:, 0] - intrinsic[0, 2]) / intrinsic[0, 0],
                (pixels[:, 1] - intrinsic[1, 2]) / intrinsic[1, 1],
                np.ones(len(pixels)),
            ],
            axis=1,
        )
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        centre = -samples.extrinsic[:, :3].T @ samples.extrinsic[:, 3]
        all_points.append(centre + rays @ samples.extrinsic[:, :3])
        all_colors.append(_sample_colors(samples.image, pixels))
    return np.concatenate(all_points), np.concatenate(all_colors)
