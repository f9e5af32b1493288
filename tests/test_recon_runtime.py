"""The recon runtime under faults and load: real uvicorn processes, real Redis, real images.

Shared scenes across replicas, leases, admission limits, cancellation, SIGTERM drain, upload
limits that hold for chunked bodies, bad input as 4xx and storage faults as 503/507.
"""

from __future__ import annotations

import io
import json
import resource
import shutil
import signal
import threading
import time
import uuid

import httpx
import numpy as np
import pytest
import redis
from PIL import Image

from shared.synthetic.photo import photo_bytes
from shared.wire.client import ReconClient
from shared.wire.settings import AgentSettings, ReconSettings
from tests.support.processes import running_service
from tests.support.scenes import orbit_views

APP = "services.recon.app:create_app"


def recon_env(data_dir, redis_url: str | None, namespace: str | None = None, **extra: str) -> dict[str, str]:
    return {
        "PYSPATIAL_DATA_DIR": str(data_dir),
        "PYSPATIAL_CACHE_NAMESPACE": namespace or f"test-{uuid.uuid4().hex[:8]}",
        "PYSPATIAL_BACKBONE": "classical",
        "PYSPATIAL_MAX_IMAGES": "6",
        "PYSPATIAL_MAX_IMAGE_BYTES": "2000000",
        "PYSPATIAL_MAX_REQUEST_BYTES": "1048576",
        "REDIS_URL": redis_url or "",
        **extra,
    }


def png(image: np.ndarray | Image.Image) -> bytes:
    buffer = io.BytesIO()
    (image if isinstance(image, Image.Image) else Image.fromarray(image)).save(buffer, format="PNG")
    return buffer.getvalue()


def jittered(images: list[np.ndarray], seed: int, intrinsics: np.ndarray | None = None) -> list[bytes]:
    """The same views with invisible noise: a scene nobody has reconstructed yet.

    With `intrinsics` (one 3x3 per view) each PNG states its focal length in EXIF as a camera's
    photo does; without it, two photos fit a range of focal lengths and a motion question whose
    answer changes over that range is (rightly) not answered."""
    rng = np.random.default_rng(seed)
    noisy = [
        np.clip(im.astype(int) + rng.integers(-2, 3, im.shape), 0, 255).astype(np.uint8) for im in images
    ]
    if intrinsics is None:
        return [png(image) for image in noisy]
    return [photo_bytes(image, k) for image, k in zip(noisy, intrinsics, strict=True)]


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=3, num_views=3)


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = recon_env(tmp_path_factory.mktemp("runtime"), redis_url, PYSPATIAL_MAX_REQUEST_PIXELS="150000000")
    with running_service(APP, env) as service:
        service.namespace = env["PYSPATIAL_CACHE_NAMESPACE"]
        yield service


def test_a_failed_reconstruction_releases_its_lease(recon, redis_url, views):
    with ReconClient(recon.url) as client:
        scene_id = client.upload_scene(jittered(views.images, 50)).scene_id
    response = httpx.post(f"{recon.url}/v1/scenes/{scene_id}/reconstruct", json={"backbone": "posed-rgbd"})
    assert response.status_code == 422 and "depth" in response.json()["detail"]
    assert redis.Redis.from_url(redis_url).keys(f"pyspatial:{recon.namespace}:recon:lease:*") == []


def test_agent_timeout_outlasts_the_longest_recon_wait():
    recon, agent = ReconSettings(), AgentSettings()
    # a request may wait reconstruct_wait_s for a lease or worker, then run one reconstruction
    assert agent.recon_timeout_s > recon.reconstruct_wait_s + recon.reconstruct_lease_s
    assert recon.reconstruct_lease_s < 60  # a crashed replica blocks a scene briefly, not for minutes


def test_two_replicas_with_separate_data_dirs_serve_each_others_scenes(tmp_path, redis_url, views):
    namespace = f"test-{uuid.uuid4().hex[:8]}"
    first_env = recon_env(tmp_path / "a", redis_url, namespace, PYSPATIAL_BACKBONE="classical")
    second_env = recon_env(tmp_path / "b", redis_url, namespace, PYSPATIAL_BACKBONE="classical")
    with running_service(APP, first_env) as first, running_service(APP, second_env) as second:
        with ReconClient(first.url) as a, ReconClient(second.url) as b:
            on_a = a.upload_scene(jittered(views.images, 1)).scene_id
            on_b = b.upload_scene(jittered(views.images, 2)).scene_id
            assert b.scene_info(on_a).num_images == 3
            assert a.scene_image(on_b, 1) == b.scene_image(on_b, 1)
            summary = b.reconstruct(on_a)
            assert summary.num_points > 0 and all(c.registered for c in summary.cameras)
            assert a.reconstruct(on_a).cached is True  # reconstructed once, on B, cached for both
    assert (tmp_path / "b" / "scenes" / on_a / "meta.json").exists()  # copied into B's own data dir


def test_healthz_stays_responsive_while_a_large_upload_decodes(recon):
    big = png(Image.new("RGB", (6000, 6000)))  # 36 MP each, a few hundred KB as PNG
    files = [("images", (f"{i}.png", big)) for i in range(4)]
    result: dict = {}

    def upload() -> None:
        response = httpx.post(recon.url + "/v1/scenes", files=files, timeout=300)
        result["status"] = response.status_code

    worker = threading.Thread(target=upload)
    worker.start()
    latencies = []
    while worker.is_alive():
        started = time.perf_counter()
        assert httpx.get(recon.url + "/healthz", timeout=30).status_code == 200
        latencies.append(time.perf_counter() - started)
        time.sleep(0.05)
    worker.join()
    assert result["status"] == 201
    assert len(latencies) >= 3, latencies  # the upload took a while, and health kept answering
    assert max(latencies) < 1.0, latencies  # before: blocked for the whole decode


def test_too_many_pixels_in_one_upload_is_refused_before_decoding(recon):
    black = png(Image.new("L", (6300, 6300)))
    files = [("images", (f"{i}.png", black)) for i in range(6)]
    response = httpx.post(recon.url + "/v1/scenes", files=files, timeout=60)
    assert response.status_code == 413 and "pixels in all" in response.json()["detail"]


def test_chunked_multipart_cannot_bypass_the_request_limit(recon):
    boundary = "pyspatial-test-boundary"

    def body():  # no Content-Length: the service must count the stream
        yield (
            f'--{boundary}\r\nContent-Disposition: form-data; name="images"; filename="a.png"\r\n'
            "Content-Type: image/png\r\n\r\n"
        ).encode()
        for _ in range(40):  # ~1.4 MB under a 1 MiB limit
            yield b"\x00" * 36_000
        yield f"\r\n--{boundary}--\r\n".encode()

    response = httpx.post(
        recon.url + "/v1/scenes",
        content=body(),
        headers={"content-type": f"multipart/form-data; boundary={boundary}"},
        timeout=60,
    )
    assert response.status_code == 413, response.text
    assert "limit" in response.json()["detail"]


def test_file_count_is_checked_before_files_are_read(recon, views):
    image = views.pngs()[0]
    files = [("images", (f"{i}.png", image)) for i in range(7)]
    response = httpx.post(recon.url + "/v1/scenes", files=files, timeout=60)
    assert response.status_code == 422 and "at most 6" in response.json()["detail"]
    depths = [("depths", (f"{i}.npy", b"x")) for i in range(13)]
    response = httpx.post(recon.url + "/v1/scenes", files=[files[0], *depths], timeout=60)
    assert response.status_code == 422 and "multipart" in response.json()["detail"]


def test_npz_depth_and_deeply_nested_extrinsics_are_4xx(recon, views):
    image = views.pngs()[0]
    archive = io.BytesIO()
    np.savez(archive, depth=np.ones((120, 160), np.float32))
    response = httpx.post(
        recon.url + "/v1/scenes",
        files=[("images", ("a.png", image)), ("depths", ("d.npz", archive.getvalue()))],
        timeout=60,
    )
    assert response.status_code == 422 and "npz" in response.json()["detail"]
    nested = "[" * 100_000 + "]" * 100_000
    response = httpx.post(
        recon.url + "/v1/scenes",
        files=[("images", ("a.png", image))],
        data={"extrinsics": nested},
        timeout=60,
    )
    assert response.status_code == 422 and "nested too deeply" in response.json()["detail"]
    assert httpx.get(recon.url + "/healthz").status_code == 200


def test_forty_thousand_camera_motion_pairs_are_refused(recon, views):
    with ReconClient(recon.url) as client:
        scene_id = client.upload_scene(jittered(views.images, 3)).scene_id
    pairs = [[1, 2]] * 40_000
    response = httpx.post(
        recon.url + "/v1/camera-motion", json={"scene_id": scene_id, "pairs": pairs}, timeout=60
    )
    assert response.status_code == 422 and "at most 1024" in response.json()["detail"]
    response = httpx.post(
        recon.url + "/v1/camera-motion", json={"scene_id": scene_id, "pairs": [[1, 2], [2, 3]]}, timeout=120
    )
    assert response.status_code == 200 and len(response.json()["motions"]) == 2


def test_unwritable_data_dir_is_a_503_that_says_so_and_readyz_reports_it(tmp_path, views):
    with running_service(APP, recon_env(tmp_path, None)) as service:
        assert httpx.get(service.url + "/readyz").json()["storage"] == "ok"
        shutil.rmtree(tmp_path / "scenes")
        (tmp_path / "scenes").write_text("a file where the scenes directory should be")
        response = httpx.post(service.url + "/v1/scenes", files=[("images", ("a.png", views.pngs()[0]))])
        assert response.status_code == 503, response.text
        assert "could not store the scene" in response.json()["detail"]
        ready = httpx.get(service.url + "/readyz")
        assert ready.status_code == 503 and ready.json()["ready"] is False
        assert "data dir" in ready.json()["storage"]


def _small_file_size_limit() -> None:
    """In the service process: files may not grow past 64 KiB (EFBIG, as a full disk would)."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a failing write instead of a killed process
    resource.setrlimit(resource.RLIMIT_FSIZE, (64 * 1024, 64 * 1024))


def test_full_storage_is_a_507(tmp_path):
    noise = np.random.default_rng(0).integers(0, 256, (160, 200, 3), dtype=np.uint8)  # ~96 KB PNG
    with running_service(APP, recon_env(tmp_path, None), preexec_fn=_small_file_size_limit) as service:
        response = httpx.post(service.url + "/v1/scenes", files=[("images", ("a.png", png(noise)))])
    assert response.status_code == 507, response.text
    assert "could not store the scene" in response.json()["detail"]


def test_queue_limit_cancellation_and_retry_after(tmp_path, redis_url, views):
    """One queue place. A job waiting on another replica's lease holds it; when its client leaves,
    the job is dropped (it never runs) and frees the place; a full queue is a 503 + Retry-After."""
    env = recon_env(tmp_path, redis_url, PYSPATIAL_MAX_QUEUED_RECONSTRUCTIONS="1")
    namespace = env["PYSPATIAL_CACHE_NAMESPACE"]
    store = redis.Redis.from_url(redis_url)
    version = _classical_version()

    def foreign_lease(scene_id: str) -> str:  # another replica at work on this scene
        key = f"pyspatial:{namespace}:recon:lease:{scene_id}:classical:{version}"
        store.set(key, "other-replica", ex=60)
        return key

    with running_service(APP, env) as service, ReconClient(service.url, timeout=300) as client:
        abandoned, queued, refused = (
            client.upload_scene(jittered(views.images, 30 + i)).scene_id for i in range(3)
        )
        leases = [foreign_lease(abandoned), foreign_lease(queued)]
        # It waits for the lease, then its client leaves. The client stays a few seconds so that a
        # loaded machine's service has queued the job before the client goes: a request it only
        # reads after its client has left may find the lease free by then and start running.
        with pytest.raises(httpx.ReadTimeout):
            httpx.post(f"{service.url}/v1/scenes/{abandoned}/reconstruct", timeout=5.0)
        time.sleep(1.0)
        outcome: dict = {}
        waiter = threading.Thread(
            target=lambda: outcome.update(
                response=httpx.post(f"{service.url}/v1/scenes/{queued}/reconstruct", timeout=300)
            )
        )
        waiter.start()  # admitted only because the abandoned job freed the queue place
        time.sleep(0.5)
        response = httpx.post(f"{service.url}/v1/scenes/{refused}/reconstruct", timeout=30)
        assert response.status_code == 503 and "queued" in response.json()["detail"], response.text
        assert int(response.headers["retry-after"]) >= 1
        store.delete(*leases)  # the other replica "crashed": the queued job takes over
        waiter.join()
        assert outcome["response"].status_code == 200, outcome["response"].text
        time.sleep(1.0)  # an abandoned job still alive would now compute its scene
        cached = b" ".join(store.keys(f"pyspatial:{namespace}:recon:*")).decode()
        assert queued in cached and abandoned not in cached, cached


def _wait_for_lease(redis_url: str, namespace: str, scene_id: str, timeout: float = 60) -> None:
    store = redis.Redis.from_url(redis_url)
    deadline = time.monotonic() + timeout
    while not store.keys(f"pyspatial:{namespace}:recon:lease:{scene_id}:*"):
        assert time.monotonic() < deadline, "the reconstruction never took its lease"
        time.sleep(0.05)


def test_sigterm_drains_within_the_drain_time_and_releases_the_lease(tmp_path, redis_url):
    slow = orbit_views(seed=4, num_views=4, width=640, height=480)
    env = recon_env(tmp_path, redis_url, PYSPATIAL_DRAIN_S="1", PYSPATIAL_MAX_REQUEST_BYTES="20000000")
    with running_service(APP, env) as service, ReconClient(service.url, timeout=300) as client:
        scene_id = client.upload_scene(jittered(slow.images, 8)).scene_id
        answers: list[httpx.Response] = []
        worker = threading.Thread(
            target=lambda: answers.append(
                httpx.post(f"{service.url}/v1/scenes/{scene_id}/reconstruct", timeout=300)
            )
        )
        worker.start()
        _wait_for_lease(redis_url, env["PYSPATIAL_CACHE_NAMESPACE"], scene_id)
        started = time.monotonic()
        service.process.send_signal(signal.SIGTERM)
        service.process.wait(timeout=30)
        exited_s = time.monotonic() - started
        worker.join()
    assert exited_s < 1 + 5, exited_s  # drain time plus shutdown, not the reconstruction's length
    (cut_off,) = answers  # the request the drain cut off has its own code, not uvicorn's 500
    assert cut_off.status_code == 503 and cut_off.headers["retry-after"] == "1", cut_off.text
    assert "shutting down" in cut_off.json()["detail"]
    leases = redis.Redis.from_url(redis_url).keys(
        f"pyspatial:{env['PYSPATIAL_CACHE_NAMESPACE']}:recon:lease:*"
    )
    assert leases == []


def test_waiters_give_up_with_a_503_after_the_wait_limit(tmp_path, redis_url, views):
    env = recon_env(tmp_path, redis_url, PYSPATIAL_RECONSTRUCT_WAIT_S="1")
    with running_service(APP, env) as service, ReconClient(service.url) as client:
        scene_id = client.upload_scene(jittered(views.images, 9)).scene_id
        # another replica's lease, alive (a real holder would renew it)
        store = redis.Redis.from_url(redis_url)
        namespace = env["PYSPATIAL_CACHE_NAMESPACE"]
        version = _classical_version()
        store.set(f"pyspatial:{namespace}:recon:lease:{scene_id}:classical:{version}", "other", ex=30)
        started = time.monotonic()
        response = httpx.post(f"{service.url}/v1/scenes/{scene_id}/reconstruct", timeout=60)
        waited = time.monotonic() - started
    assert response.status_code == 503 and "lease" in response.json()["detail"], response.text
    assert "retry-after" in response.headers and waited < 10


def _classical_version() -> str:
    """The version part of a classical reconstruction's cache key (backbone and input handling)."""
    from services.recon.backbones import create_backbone
    from services.recon.camera_inputs import INPUTS_VERSION

    return f"{create_backbone('classical').version}:in{INPUTS_VERSION}"


def test_json_upload_limits_also_hold(recon, views):
    body = json.dumps({"images": ["A" * 2_000_000]}).encode()
    response = httpx.post(
        recon.url + "/v1/scenes",
        content=iter([body[i : i + 65536] for i in range(0, len(body), 65536)]),
        headers={"content-type": "application/json"},
    )
    assert response.status_code == 413
