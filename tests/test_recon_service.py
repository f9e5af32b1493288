"""Contract tests of the reconstruction service: a real uvicorn process, real Redis, real images."""

from __future__ import annotations

import asyncio
import base64
import io
import time
import uuid

import httpx
import numpy as np
import pytest
import redis
from PIL import Image

from shared.geometry.reconstruction import Reconstruction
from shared.wire.client import ReconClient, ServiceError
from shared.wire.schemas import ReconstructionSummary
from tests.support.processes import running_service
from tests.support.scenes import orbit_views, psnr

APP = "services.recon.app:create_app"


def service_env(tmp_path, redis_url: str | None, **extra: str) -> dict[str, str]:
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path),
        "PYSPATIAL_CACHE_NAMESPACE": f"test-{uuid.uuid4().hex[:8]}",
        "PYSPATIAL_BACKBONE": "posed-rgbd",
        "PYSPATIAL_MAX_IMAGES": "6",
        "PYSPATIAL_MAX_IMAGE_BYTES": "2000000",
        "PYSPATIAL_MAX_REQUEST_BYTES": "5000000",
        "REDIS_URL": redis_url or "",
        **extra,
    }
    return env


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = service_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service(APP, env) as service:
        service.namespace = env["PYSPATIAL_CACHE_NAMESPACE"]
        yield service


@pytest.fixture(scope="module")
def client(recon) -> ReconClient:
    with ReconClient(recon.url, timeout=120) as client:
        yield client


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=3, num_views=3)


@pytest.fixture(scope="module")
def rgbd_scene(client, views) -> str:
    created = client.upload_scene(
        views.pngs(), depths=views.depths, extrinsics=views.extrinsics, intrinsics=views.intrinsics
    )
    return created.scene_id


def test_health_and_readiness(recon):
    assert httpx.get(recon.url + "/healthz").json() == {"status": "ok"}
    ready = httpx.get(recon.url + "/readyz").json()
    assert ready["ready"] is True and ready["cache"] == "redis" and ready["warnings"] == []
    assert httpx.get(recon.url + "/docs").status_code == 200
    paths = httpx.get(recon.url + "/openapi.json").json()["paths"]
    for path in (
        "/v1/scenes",
        "/v1/scenes/{scene_id}/reconstruct",
        "/v1/scenes/{scene_id}/reconstruction",
        "/v1/render",
        "/v1/camera-motion",
    ):
        assert path in paths


def test_upload_is_content_addressed(recon, client, views):
    pngs = views.pngs()
    first = client.upload_scene(pngs)
    again = client.upload_scene(pngs)
    as_json = httpx.post(
        recon.url + "/v1/scenes", json={"images": [base64.b64encode(p).decode() for p in pngs]}
    )
    reordered = client.upload_scene(pngs[::-1])
    assert len(first.scene_id) == 24 and first.num_images == 3
    assert first.image_sizes == [(160, 120)] * 3
    assert again.scene_id == first.scene_id and again.created is False
    assert as_json.status_code == 200 and as_json.json()["scene_id"] == first.scene_id
    assert reordered.scene_id != first.scene_id


@pytest.mark.parametrize(
    ("files", "status", "message"),
    [
        ([("images", ("a.txt", b"hello, not an image"))], 400, "not an image"),
        ([("images", ("t.png", b"\x89PNG\r\n\x1a\n" + b"\x00" * 40))], 400, "image 1"),
        ([("notes", ("n.txt", b"no images here"))], 422, "no images"),
        ([("images", (f"i{i}.png", b"x")) for i in range(7)], 422, "at most 6"),
        ([("images", ("big.bin", b"\x00" * 2_100_000))], 413, "limit"),
    ],
    ids=["not-image", "truncated-png", "none", "too-many", "too-big"],
)
def test_bad_uploads_get_clear_4xx(recon, files, status, message):
    response = httpx.post(recon.url + "/v1/scenes", files=files, timeout=30)
    assert response.status_code == status, response.text
    assert message in response.json()["detail"]


def test_truncated_real_png_and_huge_pixel_count_are_refused(recon, views):
    png = views.pngs()[0]
    response = httpx.post(recon.url + "/v1/scenes", files=[("images", ("cut.png", png[: len(png) // 2]))])
    assert response.status_code == 400 and "could not be decoded" in response.json()["detail"]
    buffer = io.BytesIO()
    Image.new("L", (9000, 9000)).save(buffer, format="PNG")  # 81 MP, compresses to a small file
    response = httpx.post(recon.url + "/v1/scenes", files=[("images", ("huge.png", buffer.getvalue()))])
    assert response.status_code == 413 and "pixels" in response.json()["detail"]


NAN_POSE = "[[1, 0, 0, NaN], [0, 1, 0, 0], [0, 0, 1, 0]]"  # NaN is not JSON; some clients send it anyway


def test_bad_json_and_geometry_uploads(recon, views):
    url = recon.url + "/v1/scenes"
    png64 = base64.b64encode(views.pngs()[0]).decode()
    cases = [
        (httpx.post(url, content=b"{not json", headers={"content-type": "application/json"}), "invalid", 422),
        (httpx.post(url, json={"images": ["***"]}), "base64", 400),
        (httpx.post(url, content=b"raw", headers={"content-type": "text/plain"}), "multipart", 422),
        (httpx.post(url, json={"images": [png64], "extrinsics": [[[1, 0, 0]]]}), "extrinsics", 422),
        (
            httpx.post(
                url,
                content=f'{{"images": ["{png64}"], "extrinsics": [{NAN_POSE}]}}',
                headers={"content-type": "application/json"},
            ),
            "extrinsics",
            422,
        ),
        (
            httpx.post(url, json={"images": [png64, png64], "depths": [base64.b64encode(b"zz").decode()]}),
            "npy",
            422,
        ),
    ]
    for response, message, status in cases:
        assert response.status_code == status, response.text
        assert message in response.json()["detail"]


def test_posed_rgbd_reconstruct_then_cache_hit(client, rgbd_scene, views):
    started = time.perf_counter()
    cold = client.reconstruct(rgbd_scene, backbone="posed-rgbd")
    cold_s = time.perf_counter() - started
    started = time.perf_counter()
    warm = client.reconstruct(rgbd_scene, backbone="posed-rgbd")
    warm_s = time.perf_counter() - started
    assert cold.cached is False and warm.cached is True
    assert warm_s < cold_s, (cold_s, warm_s)
    assert cold.backbone == "posed-rgbd" and cold.num_points > 10_000
    for camera, expected in zip(cold.cameras, views.extrinsics, strict=True):
        assert camera.registered and np.allclose(camera.extrinsic, expected, atol=1e-9)
        assert (camera.width, camera.height) == (160, 120)
    assert np.dot(cold.up, [0, 0, 1]) > 0.99  # the synthetic world is z-up and cameras are level


def test_cached_entry_lives_in_redis(recon, client, rgbd_scene, redis_url):
    client.reconstruct(rgbd_scene, backbone="posed-rgbd")
    keys = redis.Redis.from_url(redis_url).keys(
        f"pyspatial:{recon.namespace}:recon:{rgbd_scene}:posed-rgbd:*"
    )
    assert len(keys) == 1


def test_download_reconstruction_and_ply(client, rgbd_scene):
    summary = client.reconstruct(rgbd_scene, backbone="posed-rgbd")
    recon = client.reconstruction(rgbd_scene, backbone="posed-rgbd")
    assert isinstance(recon, Reconstruction) and recon.num_points == summary.num_points
    assert recon.depths is not None and recon.depths[0].shape == (120, 160)
    ply = client.ply(rgbd_scene, backbone="posed-rgbd")
    assert ply.startswith(b"ply\n") and f"element vertex {recon.num_points}".encode() in ply[:300]
    header_end = ply.index(b"end_header\n") + len(b"end_header\n")
    assert len(ply) - header_end == recon.num_points * 15


def test_render_reproduces_an_input_view(client, rgbd_scene, views):
    png = client.render(
        rgbd_scene, views.extrinsics[1], width=160, height=120, zoom_out=1.0, backbone="posed-rgbd"
    )
    rendered = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    assert rendered.shape == (120, 160, 3)
    blank = np.full_like(rendered, 255)
    quality, baseline = psnr(rendered, views.images[1]), psnr(blank, views.images[1])
    assert quality > 22 and quality > baseline + 12, (quality, baseline)
    jpeg = client.render(
        rgbd_scene, views.extrinsics[0], width=64, height=48, fmt="jpeg", backbone="posed-rgbd"
    )
    assert jpeg[:2] == b"\xff\xd8"


@pytest.mark.parametrize(
    ("pose", "message"),
    [
        ([[1, 0, 0, 0], [0, 1, 0, 0]], "extrinsic"),
        ("[[1, 0, 0, NaN], [0, 1, 0, 0], [0, 0, 1, 0]]", "finite"),
        ([[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]], "rotation"),
        ([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0]], "rotation"),
    ],
    ids=["wrong-shape", "nan", "scaled", "reflection"],
)
def test_render_rejects_malformed_poses(recon, rgbd_scene, pose, message):
    if isinstance(pose, str):  # NaN is not JSON; some clients send it anyway
        body = f'{{"scene_id": "{rgbd_scene}", "extrinsic": {pose}, "backbone": "posed-rgbd"}}'
        response = httpx.post(
            recon.url + "/v1/render", content=body, headers={"content-type": "application/json"}
        )
    else:
        response = httpx.post(
            recon.url + "/v1/render",
            json={"scene_id": rgbd_scene, "extrinsic": pose, "backbone": "posed-rgbd"},
        )
    assert response.status_code == 422, response.text
    assert message in str(response.json()["detail"])


def test_render_rejects_bad_sizes_and_unknown_scenes(recon, rgbd_scene, views):
    pose = views.extrinsics[0].tolist()
    for extra in ({"width": 8}, {"width": 5000}, {"zoom_out": 0}, {"format": "gif"}):
        response = httpx.post(
            recon.url + "/v1/render",
            json={"scene_id": rgbd_scene, "extrinsic": pose, "backbone": "posed-rgbd", **extra},
        )
        assert response.status_code == 422, (extra, response.text)
    response = httpx.post(recon.url + "/v1/render", json={"scene_id": "0" * 24, "extrinsic": pose})
    assert response.status_code == 404 and "upload" in response.json()["detail"]
    response = httpx.post(recon.url + "/v1/scenes/../../etc/reconstruct")
    assert response.status_code == 404


def test_unknown_and_unready_backbones(client, rgbd_scene):
    with pytest.raises(ServiceError) as unknown:
        client.reconstruct(rgbd_scene, backbone="nerf")
    assert unknown.value.status_code == 422 and "available" in unknown.value.message
    with pytest.raises(ServiceError) as unready:
        client.reconstruct(rgbd_scene, backbone="vggt")
    # No weights present: a 409 that says how to get them, not an outage.
    assert unready.value.status_code == 409 and "run `pyspatial weights pull vggt`" in unready.value.message


def test_posed_rgbd_without_geometry_is_a_clear_error(client, views):
    scene = client.upload_scene(views.pngs()[:2])
    with pytest.raises(ServiceError) as error:
        client.reconstruct(scene.scene_id, backbone="posed-rgbd")
    assert error.value.status_code == 422 and "depth" in error.value.message


def test_camera_motion_describes_known_motion(recon, client, rgbd_scene, views):
    motion = client.camera_motion(rgbd_scene, backbone="posed-rgbd")
    assert [(m.from_view, m.to_view) for m in motion.motions] == [(1, 2), (2, 3)]  # numbered from 1
    # The cameras orbit counter-clockwise (seen from above) while facing the centre: each step
    # moves the camera to its right and turns it left.
    for item in motion.motions:
        assert "right" in item.direction and item.yaw_deg > 0, item
        assert -180 < item.angle_deg < 0  # a step to the right: left-positive like the turn
    assert motion.text.count("\n") == 1
    response = httpx.post(
        recon.url + "/v1/camera-motion",
        json={"scene_id": rgbd_scene, "pairs": [[1, 8]], "backbone": "posed-rgbd"},
    )
    assert response.status_code == 422 and "view 8 does not exist" in response.json()["detail"]


def test_concurrent_reconstructs_run_once(recon, views):
    async def main() -> list[ReconstructionSummary]:
        async with httpx.AsyncClient(base_url=recon.url, timeout=120) as http:
            noisy = [
                np.clip(im.astype(int) + np.random.default_rng(7).integers(-3, 4, im.shape), 0, 255).astype(
                    np.uint8
                )
                for im in views.images
            ]
            files = [("images", (f"{i}.png", _png(im))) for i, im in enumerate(noisy)]
            scene_id = (await http.post("/v1/scenes", files=files)).json()["scene_id"]
            responses = await asyncio.gather(
                *[
                    http.post(f"/v1/scenes/{scene_id}/reconstruct", json={"backbone": "classical"})
                    for _ in range(4)
                ]
            )
            return [ReconstructionSummary.model_validate(r.json()) for r in responses]

    summaries = asyncio.run(main())
    computed = [s for s in summaries if not s.cached and not s.joined_in_flight]
    assert len(computed) == 1, [(s.cached, s.joined_in_flight) for s in summaries]
    assert all(s.num_points == computed[0].num_points for s in summaries)


def _png(image: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")
    return buffer.getvalue()


def test_memory_cache_without_redis(tmp_path, views):
    with running_service(APP, service_env(tmp_path, None)) as service, ReconClient(service.url) as client:
        assert client.readyz().cache == "memory"
        scene = client.upload_scene(
            views.pngs(), depths=views.depths, extrinsics=views.extrinsics, intrinsics=views.intrinsics
        )
        assert client.reconstruct(scene.scene_id, backbone="posed-rgbd").cached is False
        assert client.reconstruct(scene.scene_id, backbone="posed-rgbd").cached is True


def test_redis_outage_keeps_serving_and_catches_up(tmp_path, views):
    from tests.support.processes import start_redis

    own_redis = start_redis()
    port = own_redis.url.rsplit(":", 1)[1].split("/")[0]
    env = service_env(tmp_path, own_redis.url)
    try:
        with running_service(APP, env) as service, ReconClient(service.url) as client:
            scene = client.upload_scene(
                views.pngs(), depths=views.depths, extrinsics=views.extrinsics, intrinsics=views.intrinsics
            )
            own_redis.stop()
            during = client.reconstruct(scene.scene_id, backbone="posed-rgbd")
            assert during.cached is False and during.num_points > 0
            ready = client.readyz()
            assert ready.cache == "redis-unavailable" and "Redis is unreachable" in ready.warnings[0]
            assert client.reconstruct(scene.scene_id, backbone="posed-rgbd").cached is True  # from memory
            own_redis = start_redis(int(port))
            deadline = time.monotonic() + 10
            while client.readyz().cache != "redis" and time.monotonic() < deadline:
                time.sleep(0.5)
            assert client.readyz().cache == "redis"
            stored = redis.Redis.from_url(own_redis.url).keys(f"pyspatial:*:recon:{scene.scene_id}:*")
            assert len(stored) == 1  # the entry computed during the outage was written back
    finally:
        own_redis.stop()


def test_chunked_body_over_the_limit_is_refused(recon):
    def stream():  # no Content-Length: the service has to count
        yield b'{"images": ["'
        for _ in range(60):
            yield b"A" * 100_000
        yield b'"]}'

    response = httpx.post(
        recon.url + "/v1/scenes", content=stream(), headers={"content-type": "application/json"}
    )
    assert response.status_code == 413 and "limit" in response.json()["detail"]
    assert httpx.get(recon.url + "/healthz").status_code == 200


def test_replicas_sharing_redis_reconstruct_once(tmp_path, redis_url, views):
    """Two recon processes on one Redis and one data volume (as replicas would be deployed)."""
    env = service_env(tmp_path, redis_url)
    with running_service(APP, env) as first, running_service(APP, env) as second:
        noisy = [
            np.clip(im.astype(int) + np.random.default_rng(11).integers(-3, 4, im.shape), 0, 255).astype(
                np.uint8
            )
            for im in views.images
        ]
        with ReconClient(first.url) as client:
            scene_id = client.upload_scene([_png(im) for im in noisy]).scene_id

        async def main() -> list[ReconstructionSummary]:
            async with httpx.AsyncClient(timeout=120) as http:
                responses = await asyncio.gather(
                    *[
                        http.post(f"{url}/v1/scenes/{scene_id}/reconstruct", json={"backbone": "classical"})
                        for url in (first.url, second.url, first.url, second.url)
                    ]
                )
            return [ReconstructionSummary.model_validate(r.json()) for r in responses]

        summaries = asyncio.run(main())
    computed = [s for s in summaries if not s.cached and not s.joined_in_flight]
    assert len(computed) == 1, [(s.cached, s.joined_in_flight) for s in summaries]
    assert len({s.num_points for s in summaries}) == 1
    leases = redis.Redis.from_url(redis_url).keys(
        f"pyspatial:{env['PYSPATIAL_CACHE_NAMESPACE']}:recon:lease:*"
    )
    assert leases == []  # released after use


def test_a_cached_reconstruction_this_code_cannot_read_is_a_miss():
    """Replicas of another version sharing the Redis may write a newer format under the same key:
    that entry is recomputed, not a 500."""
    from services.recon.service import _readable

    recon = Reconstruction(
        points=np.zeros((1, 3), np.float32),
        colors=np.zeros((1, 3), np.uint8),
        extrinsics=np.tile(np.hstack([np.eye(3), np.zeros((3, 1))]), (2, 1, 1)),
        intrinsics=np.tile(np.eye(3), (2, 1, 1)),
        image_sizes=np.full((2, 2), 8),
        registered=[True, True],
        backbone="classical",
        backbone_version="6",
    )
    payload = recon.to_bytes()
    assert _readable(payload, "key").num_views == 2
    archive = dict(np.load(io.BytesIO(payload)))
    archive["format_version"] = np.array(99, dtype=np.int32)
    newer = io.BytesIO()
    np.savez(newer, **archive)
    assert _readable(newer.getvalue(), "key") is None
