"""A small, fixed subsample of a reconstruction for a viewer (the web page's 3D view).

With per-point confidence the subsample is sorted by it, most confident first: a viewer hides the
least confident points by drawing a shorter prefix (no filtering on its side)."""

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
    confidence = None
    if recon.point_confidence is not None:
        scores = recon.point_confidence[keep]
        keep = keep[np.argsort(-scores, kind="stable")]  # most confident first; ties keep their order
        confidence = _base64(np.ascontiguousarray(recon.point_confidence[keep], dtype="<f4"))
    positions = np.ascontiguousarray(recon.points[keep], dtype="<f4")
    colors = np.ascontiguousarray(recon.colors[keep], dtype=np.uint8)
    return PointCloudPreview(
        scene_id=scene_id,
        backbone=recon.backbone,
        num_points_total=recon.num_points,
        num_points=len(keep),
        positions=_base64(positions),
        colors=_base64(colors),
        confidence=confidence,
        cameras=cameras,
        up=up,
    )


def _base64(array: np.ndarray) -> str:
    return base64.b64encode(array.tobytes()).decode("ascii")
