"""Settings of the real services as the tests start them, in one place."""

from __future__ import annotations

import uuid
from pathlib import Path

from shared.wire.client import ReconClient


def recon_env(
    data_dir: Path | str, redis_url: str, backbone: str = "posed-rgbd", **extra: str
) -> dict[str, str]:
    """A recon service with its own data dir and its own cache namespace on the shared test Redis."""
    return {
        "PYSPATIAL_DATA_DIR": str(data_dir),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"test-{uuid.uuid4().hex[:8]}",
        "PYSPATIAL_BACKBONE": backbone,
        **extra,
    }


def upload_posed_views(recon_url: str, views) -> str:
    """Upload synthetic views with their exact depths and cameras (posed RGB-D); the scene id."""
    with ReconClient(recon_url) as client:
        return client.upload_scene(
            views.pngs(), depths=views.depths, extrinsics=views.extrinsics, intrinsics=views.intrinsics
        ).scene_id
