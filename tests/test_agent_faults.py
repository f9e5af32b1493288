"""The agent under bad input and failing infrastructure, over HTTP against real processes.

Bad input is a 4xx before anything reaches recon; a recon that is down, hung or killed mid-program
is a 503/504 that says so (with the attempts so far), never a 500 and never a 200 with a null
answer; after any error the client's next pooled request works.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import threading
import time
import uuid

import httpx
import pytest

from shared.local.services import running_service, start_service
from shared.wire.client import ReconClient, ServiceError
from tests.support.scenes import orbit_views
from tests.test_agent_service import MOTION_PROGRAM, motion_question

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
HOSTILE_SCENE_IDS = ["../../healthz", "a\u001bb", "#x", "?backbone=x", "0" * 23 + "/", "A" * 24, "0" * 25]


def recon_env(tmp_path_factory, redis_url) -> dict[str, str]:
    return {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("recon")),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"faults-{uuid.uuid4().hex[:8]}",
        "PYSPATIAL_BACKBONE": "posed-rgbd",
    }


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=5, num_views=3)


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    with running_service(RECON_APP, recon_env(tmp_path_factory, redis_url)) as service:
        yield service


@pytest.fixture(scope="module")
def agent(recon):
    env = {"PYSPATIAL_RECON_URL": recon.url, "PYSPATIAL_MAX_REQUEST_BYTES": "2000000"}
    with running_service(AGENT_APP, env) as service:
        yield service


@contextlib.contextmanager
def agent_over_a_scene(tmp_path_factory, redis_url, views, settings: dict[str, str]):
    """A recon holding the views' scene and an agent on it with `settings`: (recon, agent, scene id)."""
    with running_service(RECON_APP, recon_env(tmp_path_factory, redis_url)) as recon:
        scene_id = upload(recon.url, views)
        with running_service(AGENT_APP, {"PYSPATIAL_RECON_URL": recon.url, **settings}) as agent:
            yield recon, agent, scene_id


@contextlib.contextmanager
def hung(process):
    """`process` stopped for the block: it accepts connections and answers nothing."""
    os.kill(process.pid, signal.SIGSTOP)
    try:
        yield
    finally:
        os.kill(process.pid, signal.SIGCONT)


def upload(recon_url: str, views) -> str:
    with ReconClient(recon_url) as client:
        return client.upload_scene(
            views.pngs(), depths=views.depths, extrinsics=views.extrinsics, intrinsics=views.intrinsics
        ).scene_id


@pytest.mark.parametrize("scene_id", HOSTILE_SCENE_IDS)
def test_hostile_scene_ids_are_a_422_before_recon_is_asked(agent, scene_id):
    question = "Which way? A. left B. right"
    as_json = httpx.post(
        agent.url + "/v1/solve", json={"question": question, "scene_id": scene_id}, timeout=30
    )
    assert as_json.status_code == 422 and "scene_id" in as_json.json()["detail"]
    as_form = httpx.post(
        agent.url + "/v1/solve",
        files={"question": (None, question), "scene_id": (None, scene_id)},
        timeout=30,
    )
    assert as_form.status_code == 422 and "scene_id" in as_form.json()["detail"]


def test_client_quotes_scene_ids_into_one_path_segment(recon):
    # Unquoted, "../../healthz" would have fetched recon's /healthz and "#x" the scene list.
    with ReconClient(recon.url) as client:
        for scene_id in HOSTILE_SCENE_IDS:
            with pytest.raises(ServiceError) as error:
                client.scene_info(scene_id)
            assert error.value.status_code == 404, scene_id


def test_deeply_nested_fields_are_a_422(agent, views):
    nested = "[" * 100_000 + "]" * 100_000
    files = [("images", ("0.png", views.pngs()[0]))]
    form = httpx.post(
        agent.url + "/v1/solve", files=files, data={"question": "q?", "extrinsics": nested}, timeout=30
    )
    assert form.status_code == 422 and "extrinsics" in form.json()["detail"]
    body = b'{"question": "q?", "images": ' + b"[" * 100_000 + b"]" * 100_000 + b"}"
    as_json = httpx.post(
        agent.url + "/v1/solve", content=body, headers={"content-type": "application/json"}, timeout=30
    )
    assert as_json.status_code == 422 and "recursion" in as_json.json()["detail"]


def test_next_pooled_request_works_after_every_error(agent, recon, views):
    scene_id = upload(recon.url, views)
    with httpx.Client(base_url=agent.url, timeout=60) as client:
        errors = [
            (422, {"json": {"question": "q?", "scene_id": "../../healthz"}}),
            (404, {"json": {"question": "q?", "scene_id": "0" * 24}}),
            (400, {"json": {"question": "q?", "images": ["bm90IGFuIGltYWdl"]}}),
            (422, {"json": {"question": "From image 7, what is behind me? A. x B. y", "scene_id": scene_id}}),
            (413, {"content": b"x" * 2_100_000, "headers": {"content-type": "application/json"}}),
            (422, {"content": b"{not json", "headers": {"content-type": "application/json"}}),
        ]
        for status, request in errors:
            response = client.post("/v1/solve", **request)
            assert response.status_code == status, response.text
            assert client.get("/healthz").status_code == 200  # same pooled connection, no reset


def test_unhandled_error_is_a_json_500_and_the_connection_survives():
    with (
        running_service("tests.support.failing_app:create_app") as app,
        httpx.Client(base_url=app.url) as client,
    ):
        for _ in range(3):
            failed = client.get("/boom")
            assert failed.status_code == 500
            assert failed.json() == {
                "detail": "internal error (RuntimeError); the service log has the details"
            }
            assert client.get("/healthz").status_code == 200
        assert "Traceback" in app.log() and "secret internal state" in app.log()  # logged, not sent


def test_a_solve_past_its_deadline_is_a_504_at_the_deadline_not_the_recon_timeout(
    tmp_path_factory, redis_url, views
):
    """Recon hangs; each recon call may take 60 s, but the solve's deadline is 3 s: the solve ends
    as a 504 at about 3 s that says it timed out, and the agent's next solve is answered."""
    settings = {"PYSPATIAL_RECON_TIMEOUT_S": "60", "PYSPATIAL_SOLVE_DEADLINE_S": "3"}
    with agent_over_a_scene(tmp_path_factory, redis_url, views, settings) as (recon, agent, scene_id):
        body = {"question": motion_question(views)[0], "scene_id": scene_id}
        with hung(recon.process):
            started = time.monotonic()
            solve = httpx.post(agent.url + "/v1/solve", json=body, timeout=60)
            took = time.monotonic() - started
        assert solve.status_code == 504, solve.text
        assert "timed out" in solve.json()["detail"], solve.json()
        assert 2.5 < took < 3 + 5, took  # the deadline, not the 60 s recon timeout
        answered = httpx.post(agent.url + "/v1/solve", json=body, timeout=60)
        assert answered.status_code == 200, answered.text


def test_readyz_and_solve_when_recon_hangs_then_dies(tmp_path_factory, redis_url, views):
    settings = {"PYSPATIAL_READINESS_TIMEOUT_S": "1", "PYSPATIAL_RECON_TIMEOUT_S": "2"}
    with agent_over_a_scene(tmp_path_factory, redis_url, views, settings) as (recon, agent, scene_id):
        with hung(recon.process):
            ready = httpx.get(agent.url + "/readyz", timeout=20)  # a hang would raise here
            solve = httpx.post(
                agent.url + "/v1/solve", json={"question": "q?", "scene_id": scene_id}, timeout=30
            )
        assert ready.status_code == 503 and "did not answer /readyz in 1" in ready.json()["reason"]
        assert solve.status_code == 504 and "timed out" in solve.json()["detail"]
        assert httpx.get(agent.url + "/readyz", timeout=20).status_code == 200  # recovers
        recon.stop()
        down = httpx.get(agent.url + "/readyz", timeout=20)
        assert down.status_code == 503 and down.json()["ready"] is False
        assert "cannot reach the reconstruction service" in down.json()["reason"]
        solve = httpx.post(agent.url + "/v1/solve", json={"question": "q?", "scene_id": scene_id}, timeout=30)
        assert solve.status_code == 503 and "cannot reach" in solve.json()["detail"]
        for unavailable in (ready, down, solve):  # every 503 says when to come back
            assert int(unavailable.headers["retry-after"]) >= 1, unavailable.headers


@pytest.mark.parametrize("accept", ["application/json", "text/event-stream"])
def test_recon_killed_while_the_program_runs_is_a_503_with_the_attempts(
    tmp_path_factory, redis_url, llm, views, accept
):
    recon = start_service(RECON_APP, recon_env(tmp_path_factory, redis_url))
    try:
        scene_id = upload(recon.url, views)
        env = {
            "PYSPATIAL_RECON_URL": recon.url,
            "PYSPATIAL_CODE_MODEL": "coder",
            "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
            "PYSPATIAL_MODEL_TIMEOUT_S": "30",
        }
        llm.reset()
        llm.script([{"text": MOTION_PROGRAM, "delay_s": 2.0}], model="coder")
        question, _ = motion_question(views)
        with running_service(AGENT_APP, env) as agent:
            result: dict = {}

            def solve() -> None:
                result["response"] = httpx.post(
                    agent.url + "/v1/solve",
                    json={"question": question, "scene_id": scene_id},
                    headers={"Accept": accept},
                    timeout=120,
                )

            worker = threading.Thread(target=solve)
            worker.start()
            deadline = time.monotonic() + 60
            while not any(r["model"] == "coder" for r in llm.requests()):  # the model is "thinking"
                assert time.monotonic() < deadline and worker.is_alive()
                time.sleep(0.05)
            recon.process.kill()  # the recon service dies before the program's first tool call
            worker.join(timeout=120)
            response = result["response"]
            if accept == "text/event-stream":  # the stream had started: the last event is the error
                assert response.status_code == 200
                last_event = response.text.strip().split("\n\n")[-1].splitlines()
                assert last_event[0] == "event: error"
                body = json.loads(last_event[1].removeprefix("data: "))
                assert body["status_code"] == 503
            else:
                assert response.status_code == 503, response.text
                assert int(response.headers["retry-after"]) >= 1
                body = response.json()
            assert "reconstruction service failed while the program ran" in body["detail"]
            assert len(body["attempts"]) == 1 and body["attempts"][0]["program"].startswith("def program")
            assert "cannot reach" in body["attempts"][0]["error"]
            assert "Traceback" not in response.text
    finally:
        recon.stop()
