"""CPU ray casting of a SyntheticScene: colour, exact z-depth and object ids per pixel.

One ray per pixel through the integer pixel position (u, v), as OpenCV's pinhole model does.
Ray directions are K^-1 [u, v, 1] rotated to the world, so their camera-frame z component is 1
and the ray parameter at the hit *is* the z-depth.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import open3d as o3d
from numpy.typing import ArrayLike

from shared.synthetic.geometry import camera_centre
from shared.synthetic.scene import ROOM_OBJECT_ID, WORLD_UP, SyntheticScene
from shared.synthetic.texture import albedo

# Fixed sun-like light so differently oriented faces get different brightness.
_LIGHT_DIRECTION = np.array([0.45, 0.3, 0.84]) / np.linalg.norm([0.45, 0.3, 0.84])
_AMBIENT = 0.55
_DIFFUSE = 0.45
_BACKGROUND_RGB = np.array([40, 44, 52], np.uint8)


@dataclass
class RenderedView:
    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) float32 z-depth, 0 where the ray hit nothing
    object_ids: np.ndarray  # (H, W) int32, -1 for room surfaces and misses
    extrinsic: np.ndarray  # (3, 4) camera-from-world used for the render
    intrinsic: np.ndarray  # (3, 3)


def look_at(eye: ArrayLike, target: ArrayLike, up: ArrayLike = WORLD_UP) -> np.ndarray:
    """3x4 camera-from-world extrinsic (OpenCV axes) of a camera at ``eye`` looking at ``target``."""
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    norm = np.linalg.norm(right)
    if norm < 1e-9:
        raise ValueError("look_at: viewing direction is parallel to the up vector")
    right /= norm
    down = np.cross(forward, right)
    rotation = np.stack([right, down, forward])
    return np.hstack([rotation, (-rotation @ eye)[:, None]])


def default_intrinsic(width: int, height: int, fov_deg: float = 60.0) -> np.ndarray:
    """Square-pixel pinhole with the given horizontal field of view, principal point at the centre."""
    focal = (width / 2) / np.tan(np.radians(fov_deg) / 2)
    return np.array([[focal, 0.0, (width - 1) / 2], [0.0, focal, (height - 1) / 2], [0.0, 0.0, 1.0]])


@lru_cache(maxsize=8)
def _pixel_grid(width: int, height: int) -> np.ndarray:
    u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    return np.stack([u.ravel(), v.ravel(), np.ones(u.size)], axis=1)


def render_view(
    scene: SyntheticScene, extrinsic: np.ndarray, intrinsic: np.ndarray, width: int, height: int
) -> RenderedView:
    extrinsic = np.asarray(extrinsic, np.float64)[:3, :4]
    intrinsic = np.asarray(intrinsic, np.float64)
    rotation = extrinsic[:, :3]
    origin = camera_centre(extrinsic)

    directions = _pixel_grid(width, height) @ np.linalg.inv(intrinsic).T @ rotation
    rays = np.hstack([np.broadcast_to(origin, directions.shape), directions]).astype(np.float32)
    hits = scene.raycasting_scene.cast_rays(o3d.core.Tensor(rays))
    t_hit = hits["t_hit"].numpy()
    hit = np.isfinite(t_hit)
    triangle = hits["primitive_ids"].numpy()[hit].astype(np.int64)

    points = origin + directions[hit] * t_hit[hit, None]
    material_ids = scene.triangle_material_ids[triangle]
    colour = albedo(points, material_ids, scene.material_table)
    normals = hits["primitive_normals"].numpy()[hit].astype(np.float64)
    # Light the side of the surface the camera sees, so winding order does not matter.
    facing = np.sign(np.einsum("ij,ij->i", normals, directions[hit]))
    normals *= -np.where(facing == 0, 1.0, facing)[:, None]
    lambert = _AMBIENT + _DIFFUSE * np.clip(normals @ _LIGHT_DIRECTION, 0.0, 1.0)

    rgb = np.empty((width * height, 3), np.uint8)
    rgb[:] = _BACKGROUND_RGB
    rgb[hit] = np.clip(np.rint(colour * lambert[:, None] * 255.0), 0, 255).astype(np.uint8)
    depth = np.zeros(width * height, np.float32)
    depth[hit] = t_hit[hit]
    object_ids = np.full(width * height, ROOM_OBJECT_ID, np.int32)
    object_ids[hit] = scene.triangle_object_ids[triangle]
    return RenderedView(
        rgb=rgb.reshape(height, width, 3),
        depth=depth.reshape(height, width),
        object_ids=object_ids.reshape(height, width),
        extrinsic=extrinsic.copy(),
        intrinsic=intrinsic.copy(),
    )
