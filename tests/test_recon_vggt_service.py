"""The vggt backbone behind the real recon service: tiny published-architecture weights, real HTTP."""

from __future__ import annotations

import uuid
from pathlib import Path

import httpx
import numpy as np

from shared.local.services import running_service
from shared.wire.client import ReconClient
from tests.support.scenes import orbit_views

DATA = Path(__file__).parent / "data" / "vggt"
APP = "services.recon.app:create_app"


def vggt_env(tmp_path, checkpoint: Path) -> dict[str, str]:
    return {
        "PYSPATIAL_DATA_DIR": str(tmp_path),
        "PYSPATIAL_CACHE_NAMESPACE": f"test-{uuid.uuid4().hex[:8]}",
        "REDIS_URL": "",
        "PYSPATIAL_BACKBONE": "vggt",
        "PYSPATIAL_VGGT_CHECKPOINT": str(checkpoint),
        "PYSPATIAL_VGGT_CONFIG": str(DATA / "tiny_vggt_config.json"),
    }


def test_vggt_reconstructs_over_http(tmp_path):
    views = orbit_views(seed=2, num_views=3)
    env = vggt_env(tmp_path, DATA / "tiny_vggt.safetensors")
    with running_service(APP, env) as service, ReconClient(service.url, timeout=300) as client:
        ready = client.readyz()
        assert ready.ready and ready.backbone == "vggt"
        scene = client.upload_scene(views.pngs())
        summary = client.reconstruct(scene.scene_id)
        assert summary.backbone == "vggt" and summary.backbone_version.startswith("cfg")
        assert all(camera.registered for camera in summary.cameras) and summary.num_points > 0
        # Intrinsics are in the original image's pixels: principal point near the image centre.
        for camera in summary.cameras:
            assert abs(camera.intrinsic[0][2] - 80) < 2 and abs(camera.intrinsic[1][2] - 60) < 2
        recon = client.reconstruction(scene.scene_id)
        assert recon.depths is not None and np.isfinite(recon.points).all()
        assert client.reconstruct(scene.scene_id).cached is True


def test_mismatched_checkpoint_is_reported_not_replaced(tmp_path):
    broken = tmp_path / "broken.safetensors"
    broken.write_bytes(b"this is not a checkpoint")
    with running_service(APP, vggt_env(tmp_path, broken), ready_path="/healthz") as service:
        response = httpx.get(service.url + "/readyz")
        assert response.status_code == 503
        body = response.json()
        assert (
            body["ready"] is False
            and body["backbone"] == "vggt"
            and "broken.safetensors" in body["backbone_detail"]
        )
        with ReconClient(service.url) as client:
            scene = client.upload_scene(orbit_views(seed=2, num_views=3).pngs())
            reply = httpx.post(f"{service.url}/v1/scenes/{scene.scene_id}/reconstruct", json={})
            assert reply.status_code == 503 and "broken.safetensors" in reply.json()["detail"]
