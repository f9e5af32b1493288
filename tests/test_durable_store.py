"""The durable store of record: scenes survive Redis forgetting them (restart, FLUSHALL, eviction).

Two recon replicas with their own data dirs share one store dir (the volume every replica mounts)
and a throwaway Redis. Replica A takes the uploads; replica B, which has none of them, is asked by
id what a solve asks of recon (reconstruct, camera motion; the slow case runs real agent solves),
so every scene it serves comes from Redis or, once Redis has forgotten it, from the store.
"""

from __future__ import annotations

import io
import os
import threading
import time
import uuid
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import redis
from PIL import Image

from services.recon.durable import DurableStore
from services.recon.service import ReconService
from services.recon.store_gc import STALE_TMP_S, collect
from shared.wire.client import AgentClient, ReconClient
from shared.wire.settings import ReconSettings
from tests.support.processes import ServiceProcess, running_service, start_redis, start_service
from tests.support.scenes import orbit_views
from tests.test_agent_service import motion_question
from tests.test_recon_runtime import jittered

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"


def start_together(specs: list[tuple[str, dict[str, str]]]) -> list[ServiceProcess]:
    """Start the (app, environment) services at once (half the wait of one after the other); all or none."""
    with ThreadPoolExecutor(len(specs)) as pool:
        starting = [pool.submit(start_service, app, env) for app, env in specs]
    started = [future.result() for future in starting if future.exception() is None]
    failed = [future.exception() for future in starting if future.exception() is not None]
    if failed:
        for service in started:
            service.stop()
        raise failed[0]
    return started


def replica_env(tmp_path, name: str, redis_url: str, namespace: str) -> dict[str, str]:
    return {
        "PYSPATIAL_DATA_DIR": str(tmp_path / name),
        "PYSPATIAL_STORE_DIR": str(tmp_path / "store"),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": namespace,
        "PYSPATIAL_BACKBONE": "classical",
    }


class Stack:
    """A throwaway Redis (restartable on its port) and two replicas sharing one store dir."""

    def __init__(self, tmp_path) -> None:
        self.redis = start_redis()
        self.port = int(self.redis.url.rsplit(":", 1)[1].split("/")[0])
        namespace = f"durable-{uuid.uuid4().hex[:8]}"
        try:
            self.first, self.second = start_together(
                [(RECON_APP, replica_env(tmp_path, name, self.redis.url, namespace)) for name in "ab"]
            )
        except BaseException:
            self.redis.stop()
            raise

    def restart_redis_empty(self, while_down=lambda: time.sleep(1.0)) -> None:
        self.redis.stop()
        try:
            while_down()
        finally:
            self.redis = start_redis(self.port)

    def close(self) -> None:
        for service in (self.first, self.second):
            service.stop()
        self.redis.stop()


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    stack = Stack(tmp_path_factory.mktemp("durable"))
    try:
        yield stack
    finally:
        stack.close()


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=5, num_views=3)


def noisy_pngs(images: list[np.ndarray], seed: int) -> list[bytes]:
    """The views with the two low bits flipped at random: a new scene, and bytes that do not compress
    (to fill Redis). Fast zlib: the default level spends seconds on noise."""
    rng = np.random.default_rng(seed)
    files = []
    for image in images:
        buffer = io.BytesIO()
        Image.fromarray(image ^ rng.integers(0, 4, image.shape, dtype=np.uint8)).save(
            buffer, format="PNG", compress_level=1
        )
        files.append(buffer.getvalue())
    return files


def _upload_and_reconstruct(url: str, views, seeds) -> list[str]:
    with ReconClient(url, timeout=120) as client:
        ids = [client.upload_scene(jittered(views.images, seed)).scene_id for seed in seeds]
        for scene_id in ids:
            client.reconstruct(scene_id)
    return ids


def _by_id_under_load(url: str, scene_ids: list[str], fault) -> tuple[list[str], int]:
    """What a solve asks of recon (reconstruct, camera motion) for every scene, in a loop, while
    `fault()` runs; returns the failures and how many requests were made."""
    failures: list[str] = []
    count = 0
    done = threading.Event()

    def load() -> None:
        nonlocal count
        with ReconClient(url, timeout=60) as client:
            while not done.is_set() or count < 2 * len(scene_ids):
                scene_id = scene_ids[count % len(scene_ids)]
                try:
                    client.reconstruct(scene_id)
                    client.camera_motion(scene_id, [(1, 2)])
                except Exception as error:  # noqa: BLE001 - every failure is counted
                    failures.append(f"{scene_id}: {error}")
                count += 1

    worker = threading.Thread(target=load)
    worker.start()
    try:
        fault()
    finally:
        done.set()
        worker.join(timeout=120)
    return failures, count


def test_redis_restarted_empty_and_flushed_under_load_fails_nothing(stack, views):
    scene_ids = _upload_and_reconstruct(stack.first.url, views, range(300, 303))

    uploaded_while_down: list[str] = []

    def upload_while_down() -> None:  # stored, and served by the other replica, with no Redis at all
        uploaded_while_down.extend(_upload_and_reconstruct(stack.first.url, views, [350]))
        with ReconClient(stack.second.url, timeout=60) as client:
            assert client.camera_motion(uploaded_while_down[0], [(1, 2)]).motions

    def faults() -> None:
        time.sleep(0.2)
        stack.restart_redis_empty(upload_while_down)
        time.sleep(0.5)
        redis.Redis.from_url(stack.redis.url).flushall()
        time.sleep(0.5)

    failures, count = _by_id_under_load(stack.second.url, scene_ids, faults)
    assert failures == [] and count >= 2 * len(scene_ids)
    assert len(uploaded_while_down) == 1
    # the replica that took the uploads was restarted-from too: a fresh upload lands, and it solves
    late = _upload_and_reconstruct(stack.first.url, views, [399])
    with ReconClient(stack.second.url, timeout=60) as client:
        assert client.camera_motion(late[0], [(1, 2)]).motions


def test_a_6mb_allkeys_lru_redis_over_two_dozen_scenes_fails_nothing_by_id(stack):
    control = redis.Redis.from_url(stack.redis.url)
    control.config_set("maxmemory-policy", "allkeys-lru")
    control.config_set("maxmemory", "6mb")
    big = orbit_views(seed=5, num_views=3, width=320, height=240)  # noisy PNGs: ~0.4 MB a scene
    try:
        with ReconClient(stack.first.url, timeout=120) as client, ThreadPoolExecutor(4) as pool:
            uploads = [noisy_pngs(big.images, seed) for seed in range(500, 524)]
            ids = [created.scene_id for created in pool.map(client.upload_scene, uploads)]
        assert control.info("stats")["evicted_keys"] > 0  # Redis did forget scenes
        with ReconClient(stack.second.url, timeout=120) as other:
            infos = [other.scene_info(scene_id) for scene_id in ids]
            images = [other.scene_image(scene_id, 2) for scene_id in ids[:3]]
            motion = [other.camera_motion(ids[0], [(1, 2)])]  # the first upload: evicted first
    finally:
        control.config_set("maxmemory", "0")
    assert [info.num_images for info in infos] == [3] * 24
    assert all(image[:8] == b"\x89PNG\r\n\x1a\n" for image in images)
    assert all(m.motions for m in motion)


@pytest.mark.slow
def test_agent_solves_by_id_while_redis_restarts_empty(stack, views):
    """The same through the agent (slow: the agent's start-up and a sandboxed program a solve)."""
    scene_ids = _upload_and_reconstruct(stack.first.url, views, range(600, 612))
    question, truth = motion_question(views)
    answers: list[str] = []
    failures: list[str] = []
    with running_service(AGENT_APP, {"PYSPATIAL_RECON_URL": stack.second.url}) as agent_service:

        def solve_all() -> None:
            with AgentClient(agent_service.url, timeout=120) as agent:
                for scene_id in scene_ids:
                    try:
                        answers.append(agent.solve(question, scene_id=scene_id).answer)
                    except Exception as error:  # noqa: BLE001 - every failure is counted
                        failures.append(f"{scene_id}: {error}")

        worker = threading.Thread(target=solve_all)
        worker.start()
        time.sleep(0.3)
        stack.restart_redis_empty()
        worker.join(timeout=240)
    assert failures == []
    assert answers == [truth] * len(scene_ids)


# ---- the store itself and its GC (no processes) --------------------------------------------------


def _scene_dir(tmp_path, name: str, size: int):
    folder = tmp_path / "local" / name
    folder.mkdir(parents=True)
    (folder / "image_000").write_bytes(np.random.default_rng(size).bytes(size))
    (folder / "meta.json").write_text('{"num_images": 1}')
    return folder


def test_store_writes_whole_scenes_once_and_reads_them_back(tmp_path):
    store = DurableStore(tmp_path / "store")
    source = _scene_dir(tmp_path, "s1", 1000)
    assert store.put_scene("a" * 24, source) is True
    assert store.put_scene("a" * 24, source) is False  # immutable: the second writer drops its copy
    staging = tmp_path / "staging"
    staging.mkdir()
    assert store.get_scene("a" * 24, staging)
    assert (staging / "image_000").read_bytes() == (source / "image_000").read_bytes()
    assert not store.get_scene("b" * 24, staging)
    store.put_blob("a" * 24 + ":classical:1", b"payload")
    assert store.get_blob("a" * 24 + ":classical:1") == b"payload"
    assert store.get_blob("a" * 24 + ":classical:2") is None
    assert list(store.tmp.iterdir()) == []  # nothing left half-written


def test_gc_by_age_and_by_size_keeps_the_recently_used(tmp_path):
    store = DurableStore(tmp_path / "store")
    now = time.time()
    ids = [f"{index:024x}" for index in range(4)]
    for index, scene_id in enumerate(ids):  # 0 oldest ... 3 newest, 10 kB each
        store.put_scene(scene_id, _scene_dir(tmp_path, scene_id, 10_000))
        store.put_blob(f"{scene_id}:classical:1", b"x" * 1000)
        for path in (store.scenes / scene_id, store.reconstructions / scene_id):
            os.utime(path, (now - (4 - index) * 86400, now - (4 - index) * 86400))
    half_written = store.tmp / "scene-crashed"
    half_written.mkdir()
    os.utime(half_written, (now - STALE_TMP_S - 1, now - STALE_TMP_S - 1))

    report = collect(store, max_age_s=3.5 * 86400, now=now)
    assert report.removed == [ids[0]] and report.stale_temporaries == 1
    assert not (store.reconstructions / ids[0]).exists() and not half_written.exists()

    report = collect(store, max_bytes=25_000, now=now)  # three scenes of ~11 kB: one must go
    assert report.removed == [ids[1]]
    assert report.kept_bytes <= 25_000
    assert sorted(p.name for p in store.scenes.iterdir()) == ids[2:]
    assert store.get_blob(f"{ids[3]}:classical:1") == b"x" * 1000


def test_each_replica_runs_the_gc_when_a_limit_is_set(tmp_path):
    settings = ReconSettings(
        data_dir=tmp_path / "data",
        store_dir=tmp_path / "store",
        store_max_age_days=1e-5,  # ~0.9 s
        store_gc_interval_s=0.1,
    )
    service = ReconService(settings)
    durable = service.store.durable
    durable.put_scene("c" * 24, _scene_dir(tmp_path, "old", 100))
    collector = service.start_store_gc()
    try:
        deadline = time.monotonic() + 10
        while durable.has_scene("c" * 24) and time.monotonic() < deadline:
            time.sleep(0.1)
    finally:
        collector.stop()
    assert not durable.has_scene("c" * 24)  # older than ~0.9 s: collected by the thread
    no_limits = ReconSettings(data_dir=tmp_path / "d2", store_dir=tmp_path / "s2")
    assert ReconService(no_limits).start_store_gc() is None
