"""Contract tests of POST /v1/solve: real recon and agent processes, real Redis, real images.

The only stand-in is the hosted language model: a local OpenAI-compatible server replaying a script.
"""

from __future__ import annotations

import base64
import io
import time

import httpx
import numpy as np
import pytest
from PIL import Image

from shared.geometry.camera_motion import DIRECTIONS
from shared.local.services import running_service
from shared.wire.client import AgentClient, ServiceError
from tests.support.scenes import orbit_views
from tests.support.stack import recon_env, upload_posed_views

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"

MOTION_PROGRAM = """Reasoning: compare the two cameras.
```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.describe_camera_motion(recon)
```"""
BEHIND_PROGRAM = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    behind = pySpatial.turn_around(recon.extrinsics[0])
    return pySpatial.synthesize_novel_view(recon, behind, width=96, height=72)
```"""


def expected_direction(views, first: int, second: int) -> str:
    """Direction of camera `second` seen from camera `first`, on the floor plane of the z-up world."""
    centres = [-e[:, :3].T @ e[:, 3] for e in views.extrinsics]
    forward = views.extrinsics[first][2, :3].copy()
    forward[2] = 0
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    move = centres[second] - centres[first]
    angle = np.degrees(np.arctan2(move @ right, move @ forward))
    return DIRECTIONS[int(np.floor((angle + 22.5) / 45.0)) % 8]


def motion_question(views) -> tuple[str, str]:
    truth = expected_direction(views, 0, 1)
    options = [truth] + [d for d in ("left", "forward", "backward", "right") if d != truth][:3]
    letters = "ABCD"
    order = [options[i] for i in (2, 0, 3, 1)]
    text = "Which way did the camera move from view 1 to view 2? " + " ".join(
        f"{letter}. {option}" for letter, option in zip(letters, order, strict=True)
    )
    return text, letters[order.index(truth)]


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=5, num_views=3)


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service(RECON_APP, env) as service:
        yield service


@pytest.fixture(scope="module")
def scene_id(recon, views) -> str:
    return upload_posed_views(recon.url, views)


@pytest.fixture(scope="module")
def offline_agent(recon):
    env = {
        "PYSPATIAL_RECON_URL": recon.url,
        "PYSPATIAL_SANDBOX_WALL_S": "20",
        "PYSPATIAL_MAX_REQUEST_BYTES": "5000000",
    }
    with running_service(AGENT_APP, env) as service:
        yield service


@pytest.fixture(scope="module")
def model_agent(recon, llm):
    env = {
        "PYSPATIAL_RECON_URL": recon.url,
        "PYSPATIAL_CODE_MODEL": "coder",
        "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
        "PYSPATIAL_ANSWER_MODEL": "answerer",
        "PYSPATIAL_ANSWER_MODEL_BASE_URL": llm.base_url,
        "PYSPATIAL_MODEL_TIMEOUT_S": "2",
        "PYSPATIAL_MODEL_MAX_RETRIES": "1",
        "PYSPATIAL_SANDBOX_WALL_S": "3",
        "PYSPATIAL_SANDBOX_CPU_S": "3",
    }
    with running_service(AGENT_APP, env) as service:
        yield service


def test_offline_motion_question_is_answered_from_the_geometry(offline_agent, scene_id, views):
    question, truth = motion_question(views)
    with AgentClient(offline_agent.url) as agent:
        result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd")
    assert result.code_model == "offline-planner" and result.answer_model == "offline-answerer"
    assert "describe_camera_motion" in result.program
    assert result.clue.text and "view 1 to view 2" in result.clue.text
    assert result.answer == truth, (result.clue.text, question)
    assert result.scene_id == scene_id and result.backbone == "posed-rgbd"
    assert len(result.attempts) == 1 and result.attempts[0].error is None
    for stage in ("codegen_ms", "execution_ms", "answering_ms", "total_ms"):
        assert getattr(result.timings, stage) >= 0
    assert result.timings.execution_ms > 0


def test_offline_image_clue_gives_no_answer_with_a_reason(offline_agent, scene_id):
    question = "From image 1, what is behind me? A. a sofa B. a lamp C. a table D. a plant"
    with AgentClient(offline_agent.url) as agent:
        result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd")
    assert result.answer is None and "vision model" in result.answer_reason
    assert "turn_around" in result.program and len(result.clue.images) >= 1
    picture = Image.open(io.BytesIO(base64.b64decode(result.clue.images[0])))
    assert picture.format == "PNG" and min(picture.size) >= 16
    # Nothing behind view 1 was photographed: the view is blank and the response says why.
    drawn = np.mean(np.any(np.asarray(picture.convert("RGB")) != 255, axis=2))
    assert (drawn < 0.05) == any("not seen in the input images" in note for note in result.clue.notes)


def test_solve_with_uploaded_images_multipart(offline_agent, views):
    question, _ = motion_question(views)
    files = [("images", (f"{i}.png", png)) for i, png in enumerate(views.pngs())]
    response = httpx.post(
        offline_agent.url + "/v1/solve",
        files=files,
        data={"question": question, "backbone": "posed-rgbd"},
        timeout=120,
    )
    # posed-rgbd needs depth and cameras, which a plain image upload does not carry. Without an answer
    # model to answer from the photos alone, the answer is null and the reason says why.
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["answer"] is None and body["fallback"] is None and body["program"] is None
    assert "could not reconstruct" in body["answer_reason"] and "depth" in body["answer_reason"]
    assert "PYSPATIAL_ANSWER_MODEL" in body["answer_reason"]


@pytest.mark.parametrize(
    ("body", "status", "message"),
    [
        ({"question": "which way?"}, 422, "images"),
        ({"question": "", "scene_id": "0" * 24}, 422, "question"),
        ({"question": "which way?", "scene_id": "0" * 24}, 404, "not known"),
        ({"question": "which way?", "images": ["bm90IGFuIGltYWdl"]}, 400, "not an image"),
        ({"question": "which way?", "images": ["%%%"]}, 400, "base64"),
        ({"question": "which way?", "images": ["eA=="], "scene_id": "0" * 24}, 422, "not both"),
        ({"question": "From image 9, what is behind me? A. x B. y", "scene_id": "SCENE"}, 422, "view 9"),
    ],
    ids=["nothing", "empty-question", "unknown-scene", "not-image", "bad-base64", "both", "no-such-view"],
)
def test_bad_requests_get_clear_4xx(offline_agent, scene_id, body, status, message):
    if body.get("scene_id") == "SCENE":
        body = {**body, "scene_id": scene_id}
    response = httpx.post(offline_agent.url + "/v1/solve", json=body, timeout=60)
    assert response.status_code == status, response.text
    assert message in response.json()["detail"]


def test_model_program_is_repaired_and_answered(model_agent, llm, scene_id, views):
    question, truth = motion_question(views)
    bad = "```python\nimport os\ndef program(input_scene):\n    return os.listdir('/')\n```"
    llm.reset()
    llm.script([bad, MOTION_PROGRAM], model="coder")
    llm.script([f'{{"reasoning": "the clue says so", "answer": "{truth}"}}'], model="answerer")
    with AgentClient(model_agent.url) as agent:
        result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd")
    assert [a.error is None for a in result.attempts] == [False, True]
    assert "import" in result.attempts[0].error
    assert result.program.strip().startswith("def program") and result.answer == truth
    assert result.code_model == "coder" and result.answer_model == "answerer"
    requests = llm.requests()
    repair = [r for r in requests if r["model"] == "coder"][1]
    assert "import" in str(repair["messages"][-1]["content"])  # the error went back to the model
    answer_request = [r for r in requests if r["model"] == "answerer"][0]
    assert "view 1 to view 2" in str(answer_request["messages"])  # the clue reached the answer model


def test_reply_without_code_then_429_are_recovered(model_agent, llm, scene_id, views):
    question, truth = motion_question(views)
    llm.reset()
    llm.script(
        ["I think the camera moved.", {"status": 429, "retry_after": 0.2}, MOTION_PROGRAM], model="coder"
    )
    llm.script([f"After looking at the clue, the answer is ({truth})."], model="answerer")
    with AgentClient(model_agent.url) as agent:
        result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd", max_repairs=2)
    assert result.attempts[0].program is None and "program" in result.attempts[0].error
    assert result.answer == truth  # letter extracted from free text
    assert len([r for r in llm.requests() if r["model"] == "coder"]) == 3


def test_model_timeout_falls_back_to_the_offline_planner(model_agent, llm, scene_id, views):
    question, truth = motion_question(views)
    llm.reset()
    llm.script([{"text": "late", "delay_s": 3.0}, {"text": "late", "delay_s": 3.0}], model="coder")
    llm.script([f'{{"reasoning": "r", "answer": "{truth}"}}'], model="answerer")
    started = time.perf_counter()
    with AgentClient(model_agent.url) as agent:
        result = agent.solve(question, scene_id=scene_id, backbone="posed-rgbd")
    assert time.perf_counter() - started < 30
    assert result.code_model.startswith("offline-planner (fallback: coder")
    assert result.answer == truth


def test_runaway_program_is_stopped_and_service_keeps_serving(model_agent, llm, scene_id, views):
    spin = "```python\ndef program(input_scene):\n    n = 0\n    while True:\n        n += 1\n```"
    llm.reset()
    llm.script([spin], model="coder")
    started = time.perf_counter()
    with AgentClient(model_agent.url) as agent:
        result = agent.solve(
            "Which way did I move? A. left B. right", scene_id=scene_id, backbone="posed-rgbd", max_repairs=0
        )
        elapsed = time.perf_counter() - started
        # The model's only attempt was stopped; the planner's program ran instead, labelled as its own.
        assert result.program_source == "planner" and result.attempts[0].reply is not None
        assert "limit" in result.attempts[0].error or "timed out" in result.attempts[0].error
        assert elapsed < 15
        question, truth = motion_question(views)
        llm.script([MOTION_PROGRAM], model="coder")
        llm.script([f'{{"reasoning": "r", "answer": "{truth}"}}'], model="answerer")
        assert agent.solve(question, scene_id=scene_id, backbone="posed-rgbd").answer == truth


def test_recon_errors_pass_through_with_their_message(offline_agent, scene_id):
    with AgentClient(offline_agent.url) as agent, pytest.raises(ServiceError) as error:
        agent.solve("Which way? A. left B. right", scene_id=scene_id, backbone="nerf")
    assert (
        error.value.status_code == 422
        and "nerf" in error.value.message
        and "classical" in error.value.message
    )


def test_coverage_notes_flag_blank_views_only():
    from services.agent.stages.clue import coverage_notes
    from shared.imaging.codecs import encode_image

    blank = np.full((64, 64, 3), 255, np.uint8)
    drawn = blank.copy()
    drawn[16:48, 16:48] = (90, 60, 30)
    notes = coverage_notes([encode_image(drawn), encode_image(blank)])
    assert len(notes) == 1 and notes[0].startswith("Rendered view 2 shows almost nothing (0% of it drawn)")


def test_chunked_solve_body_over_the_limit_is_refused(offline_agent):
    def stream():  # no Content-Length: the service has to count
        yield b'{"question": "which way?", "images": ["'
        for _ in range(60):
            yield b"A" * 100_000
        yield b'"]}'

    response = httpx.post(
        offline_agent.url + "/v1/solve", content=stream(), headers={"content-type": "application/json"}
    )
    assert response.status_code == 413 and "limit" in response.json()["detail"]
