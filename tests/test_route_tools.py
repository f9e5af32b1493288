"""The sandbox tools `locate` and `plan_route`: a program in the real sandbox, its tools served by
the agent's provider over real HTTP from a real recon service (posed RGB-D two-room scene)."""

from __future__ import annotations

import numpy as np
import pytest

from services.agent.recon_tools import ReconToolProvider
from services.agent.sandbox.runner import run_program
from shared.local.services import running_service
from shared.synthetic.two_rooms import generate_two_rooms
from shared.wire.client import ReconClient
from tests.support.stack import recon_env

RECON_APP = "services.recon.app:create_app"
GOAL_VIEW = 3  # 0-based in two_rooms' arrays; programs name it GOAL_VIEW + 1, as questions count


@pytest.fixture(scope="module")
def scene(tmp_path_factory, redis_url):
    two = generate_two_rooms(2, "reachable")
    views = two.render()
    env = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service(RECON_APP, env) as recon, ReconClient(recon.url) as client:
        scene_id = client.upload_scene(
            [v.rgb for v in views],
            depths=[v.depth for v in views],
            extrinsics=two.extrinsics,
            intrinsics=[two.intrinsic] * len(views),
        ).scene_id
        yield two, views, client, scene_id


def _run(source: str, scene) -> tuple:
    two, views, client, scene_id = scene
    tools = ReconToolProvider(client, scene_id, "posed-rgbd", [b""] * len(views))
    return run_program(source, "How do I get to the spot in view 4?", len(views), tools), tools


def test_a_program_locates_the_goal_pixel_and_plans_a_route_to_it(scene):
    two = scene[0]
    pose = two.extrinsics[GOAL_VIEW]
    pixel = two.intrinsic @ (pose[:, :3] @ two.goal + pose[:, 3])
    u, v = pixel[0] / pixel[2], pixel[1] / pixel[2]
    source = (
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        f"    found = pySpatial.locate(recon, {GOAL_VIEW + 1}, {u:.2f}, {v:.2f})\n"
        "    plan = pySpatial.plan_route(recon, 1, found['point'], robot_radius=0.25)\n"
        "    far = pySpatial.locate(recon, 2, 5.0, 5.0)\n"
        "    return plan['summary'] + ' | ' + str(len(plan['steps'])) + ' | ' + str(far['point'] is None)\n"
    )
    result, tools = _run(source, scene)
    assert result.error is None, result.error
    summary, steps, _ = result.clue_text.split(" | ")
    assert summary.startswith(("Turn", "Go")) and " m long." in summary and int(steps) >= 1
    assert result.tool_calls == ["reconstruct", "locate", "plan_route", "locate"]
    assert tools._downloaded is not None and tools._downloaded.num_points > 0  # downloaded once


@pytest.mark.parametrize(
    ("call", "message"),
    [
        ("pySpatial.plan_route(recon, 9, [0, 0, 0])", "view 9 does not exist; views are numbered 1.."),
        ("pySpatial.plan_route(recon, 0, [0, 0, 0])", "view 0 does not exist; views are numbered 1.."),
        ("pySpatial.plan_route(recon, 1, [0, 0])", "3"),
        ("pySpatial.plan_route(recon, 1, [1, 1, 0], robot_radius=-1)", "robot_radius"),
        ("pySpatial.locate(recon, 1, 9999, 5)", "outside view 1's image"),
        ("pySpatial.locate(recon, 'one', 1, 1)", "view number"),
    ],
)
def test_bad_arguments_fail_the_program_with_a_reason(scene, call, message):
    source = (
        f"def program(input_scene):\n    recon = pySpatial.reconstruct(input_scene)\n    return str({call})\n"
    )
    result, _ = _run(source, scene)
    assert result.error is not None and message in result.error, result.error


def test_the_broker_checks_arguments_a_program_controls(scene):
    _, views, client, scene_id = scene
    from services.agent.sandbox.runner import _ToolBroker
    from services.agent.sandbox.worker_process import SandboxLimits, ToolFailure

    broker = _ToolBroker(ReconToolProvider(client, scene_id, "posed-rgbd", []), len(views), SandboxLimits())
    for arguments in (
        {"start_view": 0, "goal": [0, 0, float("nan")], "robot_radius": 0.25},
        {"start_view": True, "goal": [0, 0, 0], "robot_radius": 0.25},
        {"start_view": 0, "goal": "x", "robot_radius": 0.25},
    ):
        with pytest.raises(ToolFailure):
            broker.handle("plan_route", arguments)
    assert np.isfinite(broker.handle("locate", {"view": 0, "u": 160.0, "v": 200.0})["point"]).all()
