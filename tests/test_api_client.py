"""shared.wire.api, the paper's Python API, against a real reconstruction service."""

from __future__ import annotations

import json
import uuid
from collections.abc import Iterator

import numpy as np
import pytest
from PIL import Image

from shared.wire.api import Reconstruction, Scene, SpatialToolkit, pySpatial
from tests.support.processes import REPO_ROOT, ServiceProcess, start_service

EXAMPLE = REPO_ROOT / "examples" / "living_room"


@pytest.fixture(scope="module")
def recon_service(redis_url: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[ServiceProcess]:
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("api-data")),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"test-api-{uuid.uuid4().hex}",
        "PYSPATIAL_BACKBONE": "classical",
    }
    service = start_service("services.recon.app:create_app", env)
    try:
        yield service
    finally:
        service.stop()


@pytest.fixture(scope="module")
def toolkit(recon_service: ServiceProcess) -> Iterator[SpatialToolkit]:
    kit = SpatialToolkit(recon_service.url)
    yield kit
    kit.close()


@pytest.fixture(scope="module")
def recon(toolkit: SpatialToolkit) -> Reconstruction:
    return toolkit.reconstruct(Scene(EXAMPLE, question="Which way did the camera move?"))


def test_reconstruct_gives_cameras_of_every_view(recon):
    assert recon.backbone == "classical"
    assert recon.extrinsics.shape == (3, 3, 4) and recon.intrinsics.shape == (3, 3, 3)
    assert recon.registered.all()
    assert recon.image_sizes == [(480, 360)] * 3
    rotations = recon.extrinsics[:, :, :3]
    assert np.allclose(rotations @ rotations.transpose(0, 2, 1), np.eye(3), atol=1e-4)


def test_describe_camera_motion_sees_the_step_to_the_right(toolkit, recon):
    text = toolkit.describe_camera_motion(recon)
    assert text.splitlines()[0].startswith(
        "From view 1 to view 2, in view 1's image axes, the camera moved right"
    )


def test_points_are_downloaded_on_demand(recon):
    points, colors = recon.points(), recon.colors()
    assert points.shape == (recon.num_points, 3) and colors.shape == (recon.num_points, 3)
    assert np.isfinite(points).all()
    assert recon.points() is points  # fetched once


def test_novel_view_from_a_turned_pose(toolkit, recon):
    pose = toolkit.rotate_left(recon.extrinsics[0], 20.0, up=recon.up)
    image = toolkit.synthesize_novel_view(recon, pose, width=160, height=120)
    assert isinstance(image, Image.Image) and image.size == (160, 120)
    array = toolkit.synthesize_novel_view(recon, recon.extrinsics[1], width=96, height=64, as_array=True)
    assert array.shape == (64, 96, 3) and array.dtype == np.uint8 and array.std() > 5


def test_scene_from_arrays_and_the_default_toolkit_url(recon_service, monkeypatch):
    arrays = [
        np.asarray(Image.open(EXAMPLE / name))
        for name in json.loads((EXAMPLE / "example.json").read_text())["images"]
    ]
    monkeypatch.setenv("PYSPATIAL_RECON_URL", recon_service.url)
    kit = SpatialToolkit()  # reads PYSPATIAL_RECON_URL when it first needs the service
    try:
        # Arrays carry no EXIF focal: three views, from which the backbone can tell the focal.
        from_arrays = kit.reconstruct(Scene(arrays))
        assert from_arrays.num_views == 3 and from_arrays.registered.all()
    finally:
        kit.close()


def test_pose_tools_are_the_shared_ones(recon):
    start = recon.extrinsics[0]
    moved = pySpatial.move_forward(start, 0.5, up=recon.up)
    step = pySpatial.camera_center(moved) - pySpatial.camera_center(start)
    assert np.isclose(np.linalg.norm(step), 0.5)
    turned = pySpatial.turn_around(pySpatial.turn_around(start, up=recon.up), up=recon.up)
    assert np.allclose(turned, start, atol=1e-9)


def test_a_scene_needs_images(tmp_path):
    with pytest.raises(ValueError, match="at least one image"):
        Scene(tmp_path)
