"""Two recon replicas (separate data dirs, one Redis) behind a real nginx doing round-robin.

An agent pointed at nginx answers every /v1/solve with fresh images, and a replica killed while it
holds a reconstruction lease delays the others by at most one lease lifetime plus one
reconstruction.
"""

from __future__ import annotations

import contextlib
import threading
import time
import uuid
from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest
import redis

from shared.local.nginx import running_nginx
from shared.wire.client import AgentClient, ReconClient
from shared.wire.schemas import ReconstructionSummary
from tests.support.processes import running_service
from tests.support.scenes import orbit_views
from tests.test_agent_service import motion_question
from tests.test_recon_runtime import jittered

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
LEASE_S = 3  # short, so the crash test is quick; production default in shared/wire/settings.py


def replica_env(data_dir, redis_url: str, namespace: str) -> dict[str, str]:
    return {
        "PYSPATIAL_DATA_DIR": str(data_dir),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": namespace,
        "PYSPATIAL_BACKBONE": "classical",
        "PYSPATIAL_RECONSTRUCT_LEASE_S": str(LEASE_S),
    }


@pytest.fixture
def two_replicas(tmp_path, redis_url):
    namespace = f"test-{uuid.uuid4().hex[:8]}"
    with (
        running_service(RECON_APP, replica_env(tmp_path / "a", redis_url, namespace)) as first,
        running_service(RECON_APP, replica_env(tmp_path / "b", redis_url, namespace)) as second,
    ):
        yield first, second, namespace


def test_twenty_solves_with_fresh_images_through_nginx(two_replicas, tmp_path):
    first, second, _ = two_replicas
    views = orbit_views(seed=5, num_views=3)
    question, truth = motion_question(views)
    with (
        running_nginx([first.url, second.url]) as nginx,
        running_service(AGENT_APP, {"PYSPATIAL_RECON_URL": nginx.url}) as agent_service,
        AgentClient(agent_service.url, timeout=300) as agent,
    ):
        # The photos carry their focal in EXIF, as a camera's do: three views on one orbit cannot
        # self-calibrate, and without a focal the motion is reported over a range of them.
        def solve(index: int):
            return agent.solve(question, images=jittered(views.images, 100 + index, views.intrinsics))

        with ThreadPoolExecutor(4) as pool:
            results = list(pool.map(solve, range(20)))
    scene_ids = {result.scene_id for result in results}
    assert len(scene_ids) == 20  # every call a new scene
    assert [result.answer for result in results] == [truth] * 20, [r.answer_reason for r in results]
    # round-robin: each replica received uploads and fetched scenes the other one stored
    stored = [{p.name for p in (tmp_path / side / "scenes").iterdir()} & scene_ids for side in "ab"]
    assert stored[0] and stored[1] and stored[0] & stored[1], [len(s) for s in stored]


def test_killing_the_lease_holder_delays_others_by_one_lease_and_one_reconstruction(two_replicas, redis_url):
    first, second, namespace = two_replicas
    views = orbit_views(seed=4, num_views=4, width=640, height=480)
    with ReconClient(first.url) as client:
        scene_id = client.upload_scene(jittered(views.images, 40)).scene_id

    def holder() -> None:  # its client sees the connection die with the replica
        with contextlib.suppress(httpx.TransportError):
            httpx.post(f"{first.url}/v1/scenes/{scene_id}/reconstruct", timeout=300)

    doomed = threading.Thread(target=holder)
    doomed.start()
    store = redis.Redis.from_url(redis_url)
    deadline = time.monotonic() + 60
    while not (leases := store.keys(f"pyspatial:{namespace}:recon:lease:{scene_id}:*")):
        assert time.monotonic() < deadline, "the first replica never took the lease"
        time.sleep(0.05)
    # the heartbeat renews the lease while the work runs (every third of its lifetime)
    lowest = store.pttl(leases[0])
    renewed_by = time.monotonic() + LEASE_S
    while (remaining := store.pttl(leases[0])) <= lowest:
        assert time.monotonic() < renewed_by, f"the lease was not renewed ({remaining} ms left)"
        lowest = remaining
        time.sleep(0.05)

    outcome: dict = {}

    def other_replica() -> None:
        response = httpx.post(f"{second.url}/v1/scenes/{scene_id}/reconstruct", timeout=300)
        outcome["summary"] = ReconstructionSummary.model_validate(response.json())
        outcome["done"] = time.monotonic()

    waiter = threading.Thread(target=other_replica)
    waiter.start()
    time.sleep(0.3)  # the second replica is waiting on the lease now
    first.process.kill()
    killed = time.monotonic()
    waiter.join()
    doomed.join()

    summary = outcome["summary"]
    assert summary.num_points > 0 and all(c.registered for c in summary.cameras)
    assert not summary.cached and not summary.joined_in_flight  # computed after taking over the lease
    one_reconstruction_s = (summary.timings_ms["load_ms"] + summary.timings_ms["reconstruct_ms"]) / 1e3
    delay = outcome["done"] - killed
    slack_s = 1.5  # lease polling (0.25 s), HTTP, Redis
    assert delay <= LEASE_S + one_reconstruction_s + slack_s, (delay, one_reconstruction_s)
