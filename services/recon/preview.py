"""A small, fixed subsample of a reconstruction for a viewer (the web page's 3D view)."""

from __future__ import annotations

import base64

import numpy as np

from shared.geometry.reconstruction import Reconstruction
from shared.wire.schemas import CameraInfo, PointCloudPreview

MAX_PREVIEW_POINTS = 200_000


def subsample_indices(num_points: int, max_points: int) -> np.ndarray:
    """Evenly spread indices (seeded, so the same scene always gives the same preview)."""
    if num_points <= max_points:
        return np.arange(num_points)
    return np.sort(np.random.default_rng(0).choice(num_points, size=max_points, replace=False))


def point_cloud_preview(
    scene_id: str, recon: Reconstruction, cameras: list[CameraInfo], up: list[float], max_points: int
) -> PointCloudPreview:
    keep = subsample_indices(recon.num_points, max_points)
    positions = np.ascontiguousarray(recon.points[keep], dtype="<f4")
    colors = np.ascontiguousarray(recon.colors[keep], dtype=np.uint8)
    return PointCloudPreview(
        scene_id=scene_id,
        backbone=recon.backbone,
        num_points_total=recon.num_points,
        num_points=len(keep),
        positions=base64.b64encode(positions.tobytes()).decode("ascii"),
        colors=base64.b64encode(colors.tobytes()).decode("ascii"),
        cameras=cameras,
        up=up,
    )
