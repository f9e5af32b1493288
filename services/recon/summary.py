"""A reconstruction as the JSON summary clients read (`POST /v1/scenes/{id}/reconstruct`).

Cameras follow the one convention: 3x4 camera-from-world [R|t], OpenCV axes (x right, y down,
z forward), intrinsics 3x3 in pixels. An unregistered view has no extrinsic; a view without finite
intrinsics has none either. Confidence values that were not measured (NaN) are sent as null.
"""

from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np

from shared.geometry.poses import estimate_up_axis
from shared.geometry.reconstruction import Reconstruction
from shared.wire.schemas import CameraInfo, ReconstructionSummary


def finite_only(values: dict) -> dict:
    """NaN (not measured) becomes null: JSON has no NaN."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in values.items()}


def camera_infos(recon: Reconstruction) -> list[CameraInfo]:
    """Per view its pose (when registered), intrinsics (when known), size and confidence."""
    sources = recon.intrinsics_source or [None] * recon.num_views
    return [
        CameraInfo(
            view=i + 1,
            extrinsic=recon.extrinsics[i].tolist() if recon.registered[i] else None,
            intrinsic=recon.intrinsics[i].tolist() if np.all(np.isfinite(recon.intrinsics[i])) else None,
            intrinsics_source=sources[i],
            width=int(recon.image_sizes[i][0]),
            height=int(recon.image_sizes[i][1]),
            registered=bool(recon.registered[i]),
            confidence=finite_only(asdict(recon.view_confidence[i])),
        )
        for i in range(recon.num_views)
    ]


def _numbered_from_one(pair: dict) -> dict:
    """A pair's support as the wire names it: its views numbered from 1 (the geometry indexes from 0)."""
    return {**pair, "first": pair["first"] + 1, "second": pair["second"] + 1}


def scene_up(recon: Reconstruction) -> np.ndarray:
    """The scene's up axis from the registered cameras; image up (-y) when none is registered."""
    registered = recon.extrinsics[recon.registered]
    return estimate_up_axis(registered) if len(registered) else np.array([0.0, -1.0, 0.0])


def reconstruction_summary(
    scene_id: str, recon: Reconstruction, cached: bool, joined: bool, timings: dict[str, float]
) -> ReconstructionSummary:
    low, high = recon.bounds()
    return ReconstructionSummary(
        scene_id=scene_id,
        backbone=recon.backbone,
        backbone_version=recon.backbone_version,
        cameras=camera_infos(recon),
        num_points=recon.num_points,
        bounds_min=low.tolist(),
        bounds_max=high.tolist(),
        up=scene_up(recon).tolist(),
        units=recon.units or "relative",
        warnings=recon.warnings,
        pairs=[_numbered_from_one(finite_only(asdict(pair))) for pair in recon.pair_confidence],
        cached=cached,
        joined_in_flight=joined,
        timings_ms={k: round(v, 2) for k, v in timings.items()},
    )
