"""Settings of the real services as the tests start them, in one place."""

from __future__ import annotations

import contextlib
import uuid
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from shared.imaging.codecs import encode_image
from shared.local.services import running_service
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


@contextlib.contextmanager
def classical_recon(data_dir: Path | str, redis_url: str) -> Iterator[ReconClient]:
    """A client of a real recon service on the classical backbone; a few seconds per reconstruction."""
    with running_service(
        "services.recon.app:create_app", recon_env(data_dir, redis_url, "classical")
    ) as service:
        with ReconClient(service.url, timeout=120) as client:
            yield client


def upload_photos(client: ReconClient, images: list[np.ndarray]) -> str:
    """Upload bare PNGs (no EXIF, no intrinsics: the focal is unknown to the service); the scene id."""
    return client.upload_scene([encode_image(image) for image in images]).scene_id
