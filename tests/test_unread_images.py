"""A code model's image-only clue where nothing can look at images (no vision answer model).

Recorded from the live run with four in-context examples (BENCHMARKS.md): the local model rendered a
view for a "which way did I move" question, the offline answerer cannot read images, and the answer
was null although the offline planner answers the question. The clue check now sends such a program
back with a hint that names a text clue, and once the model's attempts run out the planner's
program answers, labelled as the planner's.
"""

from __future__ import annotations

import pytest

from shared.local.services import running_service
from shared.wire.client import AgentClient
from tests.support.scenes import orbit_views
from tests.support.stack import recon_env, upload_posed_views
from tests.test_agent_service import motion_question

# The live reply's program, as the model wrote it (its rendering from view 1, turned left).
RENDERING_REPLY = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    pose1 = recon.extrinsics[0]
    turned = pySpatial.rotate_left(pose1, angle=45)
    return [pySpatial.synthesize_novel_view(recon, turned)]
```"""
TEXT_REPLY = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.describe_camera_motion(recon, 1, 2)
```"""


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=5, num_views=3)


@pytest.fixture(scope="module")
def text_only_agent(tmp_path_factory, redis_url, llm, views):
    """A code model and no answer model: the offline answerer reads text clues only."""
    recon_settings = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service("services.recon.app:create_app", recon_settings) as recon:
        env = {
            "PYSPATIAL_RECON_URL": recon.url,
            "PYSPATIAL_CODE_MODEL": "coder",
            "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
            "PYSPATIAL_ANSWER_MODEL": "",
            "PYSPATIAL_MODEL_MAX_RETRIES": "0",
        }
        with running_service("services.agent.app:create_app", env) as agent:
            yield agent, upload_posed_views(recon.url, views)


def test_an_image_clue_goes_back_and_the_repair_answers(text_only_agent, llm, views):
    agent, scene_id = text_only_agent
    question, truth = motion_question(views)
    llm.reset()
    llm.script([RENDERING_REPLY, TEXT_REPLY], model="coder")
    with AgentClient(agent.url, timeout=300) as client:
        result = client.solve(question, scene_id=scene_id, max_repairs=1)
    assert result.answer == truth and result.program_source == "repaired-model"
    first = result.attempts[0]
    assert first.error_kind == "unread_images" and "no vision model answers here" in first.error
    repair = str([r for r in llm.requests() if r["model"] == "coder"][1]["messages"][-1]["content"])
    assert "describe_camera_motion(recon, 1, 2)" in repair and "can look at images" in repair


def test_when_the_repairs_run_out_the_planner_answers_labelled(text_only_agent, llm, views):
    agent, scene_id = text_only_agent
    question, truth = motion_question(views)
    llm.reset()
    llm.script([RENDERING_REPLY], model="coder")
    with AgentClient(agent.url, timeout=300) as client:
        result = client.solve(question, scene_id=scene_id, max_repairs=0)
    assert result.answer == truth and result.program_source == "planner"
    assert result.attempts[0].error_kind == "unread_images"
