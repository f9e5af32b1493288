"""POST /v1/solve as an event stream, the clue's poses and the points preview, against real services.

Real recon and agent processes, real Redis, real rendered images with exact cameras (posed-rgbd),
the offline planner and answerer: no stand-ins at all.
"""

from __future__ import annotations

import base64
import hashlib
import json

import httpx
import numpy as np
import pytest

from shared.local.services import REPO_ROOT, running_service
from shared.wire.client import AgentClient, ServiceError
from shared.wire.schemas import StageEvent
from tests.support.scenes import orbit_views
from tests.support.stack import recon_env, upload_posed_views

STAGES = ["upload", "reconstruction", "program", "execution", "answer"]
SSE = {"Accept": "text/event-stream"}


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=7, num_views=3)


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service("services.recon.app:create_app", env) as service:
        yield service


@pytest.fixture(scope="module")
def agent(recon):
    env = {"PYSPATIAL_RECON_URL": recon.url, "PYSPATIAL_CODE_MODEL": "", "PYSPATIAL_ANSWER_MODEL": ""}
    with running_service("services.agent.app:create_app", env) as service:
        yield service


@pytest.fixture(scope="module")
def scene_id(recon, views) -> str:
    return upload_posed_views(recon.url, views)


def read_events(response: httpx.Response) -> list[tuple[str, dict]]:
    """(event name, payload) pairs; comment lines (keep-alives) are skipped."""
    events, name = [], None
    for line in response.iter_lines():
        if line.startswith("event: "):
            name = line.removeprefix("event: ")
        elif line.startswith("data: "):
            events.append((name, json.loads(line.removeprefix("data: "))))
    return events


def stream(url: str, body: dict) -> tuple[httpx.Response, list[tuple[str, dict]]]:
    with httpx.stream("POST", url + "/v1/solve", json=body, headers=SSE, timeout=120) as response:
        return response, read_events(response) if response.status_code == 200 else []


def test_stages_arrive_in_order_then_the_result_with_the_clue_poses(agent, scene_id, views):
    question = "From image 2, what is behind me? A. a sofa B. a lamp C. a table D. a plant"
    response, events = stream(agent.url, {"question": question, "scene_id": scene_id})
    assert response.headers["content-type"].startswith("text/event-stream")
    names = [name for name, _ in events]
    assert names[-1] == "result" and names.count("result") == 1 and "error" not in names
    stages = [StageEvent.model_validate(payload) for name, payload in events if name == "stage"]
    started = [e.stage for e in stages if e.state == "started"]
    assert started == STAGES, started
    ends = {e.stage: e.state for e in stages if e.state != "started"}
    assert ends == {"upload": "done", "reconstruction": "done", "program": "done", "execution": "done"} | {
        "answer": "failed"  # no honest answer offline: a vision question
    }
    elapsed = [e.elapsed_ms for e in stages]
    assert elapsed == sorted(elapsed)
    assert "3 of 3 views placed" in next(
        e.detail for e in stages if e.stage == "reconstruction" and e.state == "done"
    )

    result = events[-1][1]["result"]
    assert result["answer"] is None and "vision model" in result["answer_reason"]
    # The rendered view says where it was rendered from: view 2 turned around in place.
    clue = result["clue"]
    assert len(clue["views"]) == len(clue["images"]) >= 1
    view = clue["views"][0]
    assert view["source"] == "rendered" and view["input_view"] is None
    pose = np.asarray(view["extrinsic"])
    truth = views.extrinsics[1]
    centre = -pose[:, :3].T @ pose[:, 3]
    assert np.allclose(centre, -truth[:, :3].T @ truth[:, 3], atol=1e-4)
    # Turned about the (z) up axis: the horizontal part of the viewing direction is reversed.
    assert np.allclose(pose[2, :2], -truth[2, :2], atol=1e-4) and np.isclose(pose[2, 2], truth[2, 2])


def test_the_stream_and_plain_json_give_the_same_answer(agent, scene_id, views):
    question = "Which way did the camera move from view 1 to view 2? A. left B. right C. up D. down"
    with AgentClient(agent.url) as client:
        seen: list[StageEvent] = []
        streamed = client.solve_with_progress(question, scene_id=scene_id, on_stage=seen.append)
        plain = client.solve(question, scene_id=scene_id)
    assert streamed.answer == plain.answer and streamed.answer is not None
    assert streamed.program == plain.program and streamed.clue.text == plain.clue.text
    assert [e.stage for e in seen if e.state == "started"] == STAGES


def test_failures_during_the_solve_are_error_events(agent):
    response, events = stream(agent.url, {"question": "where? A. x B. y", "scene_id": "0" * 24})
    assert response.status_code == 200
    assert [name for name, _ in events] == ["stage", "error"]
    error = events[-1][1]
    assert error["status_code"] == 404 and "not known" in error["detail"] and error["stage"] == "upload"
    # The client raises what plain /v1/solve would have answered.
    with AgentClient(agent.url) as client, pytest.raises(ServiceError) as raised:
        client.solve_with_progress("where? A. x B. y", scene_id="0" * 24)
    assert raised.value.status_code == 404


def test_unreadable_image_names_its_number(agent, views):
    images = [base64.b64encode(views.pngs()[0]).decode(), base64.b64encode(b"not a photo").decode()]
    response, events = stream(agent.url, {"question": "where? A. x B. y", "images": images})
    error = events[-1][1]
    assert error["status_code"] == 400 and error["detail"].startswith("image 2 is not an image")


def test_requests_refused_before_the_solve_are_plain_4xx(agent):
    response = httpx.post(
        agent.url + "/v1/solve", content=b"{", headers={**SSE, "Content-Type": "application/json"}
    )
    assert response.status_code == 422 and "invalid request" in response.json()["detail"]


def test_points_preview_is_a_bounded_subsample_with_the_cameras(agent, scene_id, views):
    response = httpx.get(f"{agent.url}/v1/scenes/{scene_id}/points", params={"max_points": 500}, timeout=60)
    assert response.status_code == 200, response.text
    preview = response.json()
    assert preview["num_points"] == 500 < preview["num_points_total"]
    positions = np.frombuffer(base64.b64decode(preview["positions"]), dtype="<f4").reshape(-1, 3)
    colors = np.frombuffer(base64.b64decode(preview["colors"]), dtype=np.uint8).reshape(-1, 3)
    assert len(positions) == len(colors) == 500 and np.all(np.isfinite(positions))
    assert [c["registered"] for c in preview["cameras"]] == [True] * 3
    assert np.allclose(preview["cameras"][0]["extrinsic"], views.extrinsics[0], atol=1e-5)
    missing = httpx.get(f"{agent.url}/v1/scenes/{'0' * 24}/points", timeout=60)
    assert missing.status_code == 404 and "not known" in missing.json()["detail"]


def test_page_and_its_assets_are_served(agent):
    page = httpx.get(agent.url + "/")
    assert page.status_code == 200 and '<canvas id="viewer"' in page.text
    for asset in ("/web/app.js", "/web/viewer.js", "/web/vendor/three-0.187.0/three.module.js"):
        assert httpx.get(agent.url + asset).status_code == 200, asset
    example = httpx.get(agent.url + "/v1/example").json()
    image = httpx.get(agent.url + example["images"][0])
    assert image.status_code == 200 and image.content.startswith(b"\x89PNG")
    assert httpx.get(agent.url + "/v1/example/images/..%2Fexample.json").status_code == 404


def test_vendored_libraries_are_the_published_files():
    """The committed three.js / highlight.js files are byte for byte what scripts/vendor_web.sh fetched."""
    vendor = REPO_ROOT / "services" / "agent" / "web" / "vendor"
    sums = [line.split() for line in (vendor / "SHA256SUMS").read_text().splitlines() if line.strip()]
    assert {name for _, name in sums} >= {
        "three-0.187.0/three.module.js",
        "three-0.187.0/OrbitControls.js",
        "highlight-11.11.1/LICENSE",
    }
    for digest, name in sums:
        assert hashlib.sha256((vendor / name).read_bytes()).hexdigest() == digest, name
