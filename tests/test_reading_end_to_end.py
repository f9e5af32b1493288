"""Questions read by meaning, end to end: a real recon service and a real agent over HTTP, on a
synthetic room photographed by cameras built to move one known way.

View 2 is view 1 stepped sideways; view 3 is view 1 raised and turned. Each question is worded
the way the old parser did not know, and the right option is the one whose words state the
motion the cameras were built with. The offline planner writes the program (the pair from the
reading, camera-to-camera position from the reconstruction, not from renders), the offline
answerer matches the claims; one solve must abstain because its pair reads two ways; and a code
model (the scripted stand-in) that writes describe_camera_motion for the asked pair is answered
from the reading.
"""

from __future__ import annotations

import httpx
import numpy as np
import pytest

from shared.geometry.poses import axis_angle_matrix
from shared.local.services import running_service
from shared.synthetic import default_intrinsic, generate_scene, look_at, render_view
from tests.support.scenes import PosedViews
from tests.support.scripted_llm import ScriptedLLM
from tests.support.stack import recon_env, upload_posed_views

SIDESTEP_M = 0.6  # view 2: this far along view 1's x axis (negative: to the left)
SIDE = -1.0
RISE_M = 0.8  # view 3: this far up (along view 1's -y) ...
TURN_DEG = 25.0  # ... and turned this far to the right (about view 1's up axis)


def _camera(extrinsic: np.ndarray, step_in_camera: np.ndarray, rotation_in_camera: np.ndarray) -> np.ndarray:
    """View 1's camera moved by a step and a rotation both given in view 1's own axes."""
    rotation, translation = extrinsic[:, :3], extrinsic[:, 3]
    centre = -rotation.T @ translation + rotation.T @ step_in_camera
    new_rotation = rotation_in_camera.T @ rotation
    return np.hstack([new_rotation, (-new_rotation @ centre)[:, None]])


def _views() -> PosedViews:
    scene = generate_scene(5)
    centre = scene.room_centre.copy()
    centre[2] = 0.7
    eye = centre + np.array([0.0, -1.6, 0.7])
    first = look_at(eye, centre)
    down = np.array([0.0, 1.0, 0.0])  # camera y points down; a right turn is about +y
    cameras = [
        first,
        _camera(first, np.array([SIDE * SIDESTEP_M, 0.0, 0.0]), np.eye(3)),
        _camera(first, -RISE_M * down, axis_angle_matrix(down, TURN_DEG)),
    ]
    intrinsic = default_intrinsic(160, 120, 60.0)
    rendered = [render_view(scene, camera, intrinsic, 160, 120) for camera in cameras]
    return PosedViews(
        images=[v.rgb for v in rendered],
        depths=[v.depth for v in rendered],
        extrinsics=np.stack([v.extrinsic for v in rendered]),
        intrinsics=np.stack([v.intrinsic for v in rendered]),
        object_names=scene.object_names,
    )


@pytest.fixture(scope="module")
def stack(tmp_path_factory, redis_url, llm: ScriptedLLM):
    with running_service(
        "services.recon.app:create_app", recon_env(tmp_path_factory.mktemp("r"), redis_url)
    ) as recon:
        offline = {"PYSPATIAL_RECON_URL": recon.url, "PYSPATIAL_CODE_MODEL": "", "PYSPATIAL_ANSWER_MODEL": ""}
        model = {
            **offline,
            "PYSPATIAL_CODE_MODEL": "coder",
            "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
            "PYSPATIAL_MODEL_TIMEOUT_S": "5",
            "PYSPATIAL_MODEL_MAX_RETRIES": "0",
        }
        with (
            running_service("services.agent.app:create_app", offline) as agent,
            running_service("services.agent.app:create_app", model) as model_agent,
        ):
            agent.scene_id = upload_posed_views(recon.url, _views())
            agent.model_url = model_agent.url
            yield agent


def _solve(url: str, scene_id: str, question: str) -> dict:
    body = {"question": question, "scene_id": scene_id, "backbone": "posed-rgbd"}
    response = httpx.post(url + "/v1/solve", json=body, timeout=180)
    assert response.status_code == 200, response.text
    return response.json()


def _options(right: str, wrong: list[str], letter: str) -> tuple[str, str]:
    """The options text with `right` at `letter`, the distractors around it."""
    letters = "ABCD"[: len(wrong) + 1]
    texts = list(wrong)
    texts.insert(letters.index(letter), right)
    return " ".join(f"{k}. {t}" for k, t in zip(letters, texts, strict=True)), letter


def test_a_reworded_translation_question(stack) -> None:
    right = "Sidestepped to the left" if SIDE < 0 else "Sidestepped to the right"
    wrong = ["Sidestepped to the right" if SIDE < 0 else "Sidestepped to the left", "Climbed", "Withdrew"]
    options, truth = _options(right, wrong, "C")
    result = _solve(
        stack.url,
        stack.scene_id,
        f"Going from snapshot one to snapshot two, how was the rig displaced? {options}",
    )
    assert result["answer"] == truth, (result["answer_reason"], result["clue"])
    reading = result["reading"]
    assert reading["views"] == [1, 2] and reading["quantity"] == "translation" and reading["views_certain"]
    assert "describe_camera_motion(recon, 1, 2)" in result["program"]
    answer_step = result["steps"][-1]
    assert answer_step["reading"] == reading["summary"]


def test_a_camera_to_camera_position_question_is_read_from_the_reconstruction(stack) -> None:
    options, truth = _options("Above it", ["Below it", "Behind it", "To its left"], "B")
    question = f"Where was the third photo taken, relative to the first camera? {options}"
    result = _solve(stack.url, stack.scene_id, question)
    assert result["reading"]["quantity"] == "position" and result["reading"]["views"] == [1, 3]
    assert "describe_camera_motion(recon, 1, 3)" in result["program"]
    assert "synthesize_novel_view" not in result["program"]
    assert result["answer"] == truth, (result["answer_reason"], result["clue"])
    assert "position of the second camera" in result["reasoning"]


def test_a_rotation_question_in_other_words(stack) -> None:
    right, wrong = ("Turned right", "Turned left") if TURN_DEG > 0 else ("Turned left", "Turned right")
    options, truth = _options(right, [wrong], "A")
    question = (
        "Apart from moving, which way did the camera end up pointing in image 3 compared with image 1? "
        + options
    )
    result = _solve(stack.url, stack.scene_id, question)
    assert result["reading"]["views"] == [1, 3] and result["reading"]["quantity"] == "rotation"
    assert result["answer"] == truth, (result["answer_reason"], result["clue"])


def test_a_pair_that_reads_two_ways_abstains_and_says_why(stack) -> None:
    question = (
        "From image 1 to image 2 and from image 2 to image 3, which way did the camera shift? "
        + "A. Left B. Right"
    )
    result = _solve(stack.url, stack.scene_id, question)
    assert result["answer"] is None
    assert result["reading"]["abstain_reason"] and "two readings" in result["answer_reason"]


def test_a_model_program_is_answered_from_the_reading(stack, llm: ScriptedLLM) -> None:
    """The stem has no motion verb (the old parser's family was "unknown"): the options lead."""
    right = "It sidestepped left" if SIDE < 0 else "It sidestepped right"
    options, truth = _options(right, ["It sidestepped right" if SIDE < 0 else "It sidestepped left"], "B")
    # ("Comparing snapshot 1 with snapshot 2" reads two ways, 1 -> 2 by the order of mention or
    # 2 -> 1 as "1 compared with 2", so it abstains: tests/test_pair_roles.py.)
    question = f"Between snapshot 1 and snapshot 2: {options}"
    program = (
        "```python\ndef program(input_scene):\n    recon = pySpatial.reconstruct(input_scene)\n"
        "    return pySpatial.describe_camera_motion(recon, 1, 2)\n```"
    )
    llm.reset()
    llm.script([program], model="coder")
    result = _solve(stack.model_url, stack.scene_id, question)
    assert result["program_source"] == "model", result
    assert result["answer"] == truth and result["answer_method"] == "offline_text", result["answer_reason"]
    assert result["reading"]["quantity"] == "translation" and result["reading"]["views"] == [1, 2]


def test_an_abstention_on_a_model_program_is_not_handed_to_a_text_model(stack, llm: ScriptedLLM) -> None:
    """The pair reads two ways: the reading abstains, and the code model is not asked to guess."""
    question = "From image 1 to image 2 and from image 2 to image 3, which way did it shift? A. Left B. Right"
    program = (
        "```python\ndef program(input_scene):\n    recon = pySpatial.reconstruct(input_scene)\n"
        "    return pySpatial.describe_camera_motion(recon, 1, 2)\n```"
    )
    llm.reset()
    llm.script([program, '{"reasoning": "a guess", "answer": "A"}'], model="coder")
    result = _solve(stack.model_url, stack.scene_id, question)
    assert result["program_source"] == "model" and result["answer"] is None
    assert "two readings" in result["answer_reason"]
    assert len(llm.requests()) == 1  # the program only: no answer was asked of the text model
