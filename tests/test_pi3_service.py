"""Pi3X end to end: weights pulled from a stand-in of the hub with `pyspatial weights pull`, found
in the hub cache by a real recon service (real HTTP, `auto` backbone), then reconstruct, render
and camera motion, in metres. And the backbone menu that tells the truth."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import uuid
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest

from shared.local.services import running_service
from shared.wire.client import AgentClient, ReconClient, ServiceError
from tests.support import pi3_fixtures
from tests.support.hub_standin import HubStandIn
from tests.support.scenes import orbit_views
from tests.test_agent_service import motion_question
from tests.test_weights_cli import PI3_DATA, ROOT, run_weights

APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"


@pytest.fixture(scope="module")
def pulled_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A hub cache into which `pyspatial weights pull pi3x` put the tiny Pi3X from the stand-in."""
    root = tmp_path_factory.mktemp("hub")
    hub = HubStandIn()
    hub.host("yyfz233/Pi3X", "model.safetensors", PI3_DATA / "tiny_pi3x.safetensors")
    url = hub.start()
    try:
        pulled = run_weights(root, url, "pull", "pi3x")
        assert pulled.returncode == 0, pulled.stderr
    finally:
        hub.stop()
    yield root / "hf"


def recon_env(tmp_path: Path, hf_home: Path, backbone: str = "auto") -> dict[str, str]:
    return {
        "PYSPATIAL_DATA_DIR": str(tmp_path / "data"),
        "PYSPATIAL_CACHE_NAMESPACE": f"test-{uuid.uuid4().hex[:8]}",
        "REDIS_URL": "",
        "PYSPATIAL_BACKBONE": backbone,
        "PYSPATIAL_PI3X_CONFIG": str(PI3_DATA / "tiny_pi3x_config.json"),
        "PYSPATIAL_PI3_CONFIG": str(PI3_DATA / "tiny_pi3_config.json"),
        "PYSPATIAL_PI3_PIXEL_LIMIT": str(pi3_fixtures.input_pixels()),  # tiny weights: small network images
        "HF_HOME": str(hf_home),
        "HF_HUB_OFFLINE": "1",  # the service never downloads; offline proves it
    }


def test_pulled_pi3x_reconstructs_renders_and_describes_motion_in_metres(
    tmp_path: Path, pulled_cache: Path
) -> None:
    views = orbit_views(seed=3, num_views=3)  # synthetic photos: their EXIF focal conditions Pi3X
    with running_service(APP, recon_env(tmp_path, pulled_cache)) as service:
        with ReconClient(service.url, timeout=300) as client:
            assert client.readyz().ready
            scene = client.upload_scene(views.pngs())
            summary = client.reconstruct(scene.scene_id)
            assert summary.backbone == "pi3x" and summary.units == "metres"  # auto: Pi3X is pulled
            assert all(camera.registered for camera in summary.cameras) and summary.num_points > 0
            assert [camera.intrinsics_source for camera in summary.cameras] == ["exif"] * 3
            for camera, intrinsic in zip(summary.cameras, views.intrinsics, strict=True):
                np.testing.assert_allclose(camera.intrinsic, intrinsic, rtol=1e-3)
                assert (camera.width, camera.height) == (160, 120)
            raw = httpx.post(f"{service.url}/v1/scenes/{scene.scene_id}/reconstruct", json={}, timeout=60)
            assert raw.json()["units"] == "metres"

            png = client.render(scene.scene_id, summary.cameras[0].extrinsic, width=64, height=48)
            assert png.startswith(b"\x89PNG")
            motion = client.camera_motion(scene.scene_id)
            assert len(motion.motions) == 2 and all(item.units == "metres" for item in motion.motions)
            for item in motion.motions:
                if item.direction not in (None, "no significant movement"):
                    assert f"moved {item.distance:.2f} m " in item.sentence, item.sentence
            stored = client.reconstruction(scene.scene_id)
            assert stored.units == "metres"
        # Through the agent (offline planner): `auto` ran Pi3X, and the response says so.
        agent_env = {"PYSPATIAL_RECON_URL": service.url, "PYSPATIAL_SANDBOX_WALL_S": "20"}
        with running_service(AGENT_APP, agent_env) as agent, AgentClient(agent.url, timeout=300) as solver:
            question, _ = motion_question(views)
            result = solver.solve(question, scene_id=scene.scene_id, backbone="auto")
        assert result.backbone == "pi3x", result
        # Metric: a step is said with its length (random tiny weights may also make it no step at all).
        for line in result.clue.text.splitlines():
            assert re.search(r"moved \d+\.\d\d m ", line) or "neither moved" in line or "stayed" in line, line


def test_the_backbone_menu_tells_what_can_run_and_why_not(tmp_path: Path, pulled_cache: Path) -> None:
    with running_service(APP, recon_env(tmp_path, pulled_cache, backbone="classical")) as service:
        menu = httpx.get(f"{service.url}/v1/backbones", timeout=30).json()
        entries = {entry["name"]: entry for entry in menu["backbones"]}
        assert {"classical", "posed-rgbd", "vggt", "pi3", "pi3x"} <= set(entries)
        assert entries["pi3x"]["available"] is True and entries["pi3x"]["units"] == "metres"
        assert entries["pi3x"]["reason"] is None and entries["pi3x"]["device"] == "cpu"
        for name in ("vggt", "pi3"):
            assert entries[name]["available"] is False and entries[name]["units"] == "relative"
            assert entries[name]["reason"] == f"weights not present: run `pyspatial weights pull {name}`"
        assert entries["classical"]["available"] is True and entries["classical"]["units"] == "relative"
        assert menu["auto"] == "pi3x" and menu["default"] == "classical"
        assert set(menu["available"]) == {"auto", "classical", "posed-rgbd", "pi3x"}

        with ReconClient(service.url, timeout=120) as client:
            scene = client.upload_scene(orbit_views(seed=3, num_views=2).pngs())
            with pytest.raises(ServiceError) as refused:
                client.reconstruct(scene.scene_id, backbone="pi3")
        assert refused.value.status_code == 409
        assert "backbone pi3 is not available here" in refused.value.message
        assert "run `pyspatial weights pull pi3`" in refused.value.message


def test_without_pulled_weights_auto_is_classical_and_nothing_is_offered_that_cannot_run(
    tmp_path: Path,
) -> None:
    with running_service(APP, recon_env(tmp_path, tmp_path / "empty-hf")) as service:
        menu = httpx.get(f"{service.url}/v1/backbones", timeout=30).json()
        assert menu["auto"] == "classical" and set(menu["available"]) == {"auto", "classical", "posed-rgbd"}
        with ReconClient(service.url, timeout=300) as client:
            scene = client.upload_scene(orbit_views(seed=4, num_views=3).pngs())
            summary = client.reconstruct(scene.scene_id)  # the default is auto
        assert summary.backbone == "classical" and summary.units == "relative"
        # The command line offers only what the service can run, and says why not before uploading.
        refused = subprocess.run(
            [sys.executable, "-m", "cli.main", "reconstruct", "examples/living_room", "--backbone", "pi3x"],
            cwd=ROOT,
            env={**os.environ, "PYSPATIAL_RECON_URL": service.url, "COLUMNS": "200"},
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert refused.returncode == 2
        assert "backbone pi3x is not available on this service: weights not present: run `pyspatial" in (
            " ".join(refused.stderr.split())
        )
