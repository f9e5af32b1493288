"""POST /v1/route over real HTTP: real recon and agent processes, real Redis, rendered posed RGB-D.

Plans are driven on the scene's true geometry (``execute_steps``), so a wrong turn sign or a
route through furniture fails here, not only in the benchmark.
"""

from __future__ import annotations

import httpx
import numpy as np
import pytest

from shared.local.services import running_service
from shared.synthetic.two_rooms import execute_steps, generate_two_rooms
from shared.wire.client import AgentClient, ServiceError
from tests.support.stack import recon_env

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
GOAL_VIEW = 3  # two_rooms: the view that looks at the goal


def _upload_arguments(two, views, blank_corner: bool = False) -> dict:
    depths = [v.depth.copy() for v in views]
    if blank_corner:  # nothing reconstructed in view 2's top-left corner
        depths[1][:24, :24] = 0.0
    return {
        "images": [v.rgb for v in views],
        "depths": depths,
        "extrinsics": two.extrinsics,
        "intrinsics": [two.intrinsic] * len(views),
    }


def goal_pixel(two) -> dict:
    pose = two.extrinsics[GOAL_VIEW]
    pixel = two.intrinsic @ (pose[:, :3] @ two.goal + pose[:, 3])
    return {"view": GOAL_VIEW + 1, "u": float(pixel[0] / pixel[2]), "v": float(pixel[1] / pixel[2])}


@pytest.fixture(scope="module")
def scenes():
    reachable, narrow = generate_two_rooms(2, "reachable"), generate_two_rooms(3, "narrow_door")
    return {"reachable": (reachable, reachable.render()), "narrow": (narrow, narrow.render())}


@pytest.fixture(scope="module")
def recon_and_agent(tmp_path_factory, redis_url, llm):
    """The plain agent and one whose code model is the scripted stand-in, on one recon service."""
    env = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service(RECON_APP, env) as recon:
        with running_service(AGENT_APP, {"PYSPATIAL_RECON_URL": recon.url}) as plain:
            coder = {
                "PYSPATIAL_RECON_URL": recon.url,
                "PYSPATIAL_CODE_MODEL": "coder",
                "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
                "PYSPATIAL_ANSWER_MODEL": "",
            }
            with running_service(AGENT_APP, coder) as with_model:
                yield plain, with_model


@pytest.fixture(scope="module")
def agent(recon_and_agent):
    return recon_and_agent[0]


@pytest.fixture(scope="module")
def planned(agent, scenes):
    two, views = scenes["reachable"]
    with AgentClient(agent.url) as client:
        return client.route({"pixel": goal_pixel(two)}, start_view=1, **_upload_arguments(two, views, True))


def test_a_pixel_goal_gives_steps_that_reach_it_on_the_true_geometry(planned, scenes):
    two, _ = scenes["reachable"]
    assert planned.reachable and planned.units == "metres" and planned.backbone == "posed-rgbd"
    assert planned.turn_convention == "left-positive" and len(planned.sentences) == len(planned.steps)
    assert np.linalg.norm(np.array(planned.goal_located) - two.goal) < 0.05
    run = execute_steps(two, [step.model_dump() for step in planned.steps], 0.25)
    assert not run.collided and np.linalg.norm(run.end - two.goal[:2]) <= 0.3
    assert planned.length >= planned.straight_line and planned.clearance > 0
    assert len(planned.path_world) == len(planned.path_start_camera) == len(planned.steps) + 1


def test_the_same_scene_by_id_with_a_goal_in_the_start_camera(agent, planned, scenes):
    two, _ = scenes["reachable"]
    pose = two.extrinsics[0]
    in_camera = (pose[:, :3] @ two.goal + pose[:, 3]).tolist()
    with AgentClient(agent.url) as client:
        again = client.route({"point_start_camera": in_camera}, scene_id=planned.scene_id, start_view=1)
    assert again.reachable and again.scene_id == planned.scene_id
    assert again.length == pytest.approx(planned.length, abs=0.1)


@pytest.mark.parametrize(
    ("goal", "message"),
    [
        ({"pixel": {"view": 2, "u": 400, "v": 10}}, "outside view 2's image"),
        ({"pixel": {"view": 2, "u": 5, "v": 5}}, "nothing is reconstructed there (view 2 has no depth"),
        ({"point_world": "dividing wall"}, "inside an obstacle"),
        ({"pixel": {"view": 9, "u": 5, "v": 5}}, "view 9 does not exist"),
        ({}, "exactly one of"),
    ],
)
def test_bad_goals_are_422s_that_say_which(agent, planned, scenes, goal, message):
    two, _ = scenes["reachable"]
    if goal.get("point_world") == "dividing wall":
        goal = {"point_world": [two.divider_x, two.door[0] - 0.5, 0.3]}
    response = httpx.post(
        agent.url + "/v1/route",
        json={"scene_id": planned.scene_id, "start_view": 1, "goal": goal},
        timeout=60,
    )
    assert response.status_code == 422, response.text
    assert message in response.json()["detail"]


def test_an_unreachable_goal_is_a_200_with_the_reason(agent, scenes):
    two, views = scenes["narrow"]
    with AgentClient(agent.url) as client:
        plan = client.route(
            {"point_world": two.goal.tolist()}, robot={"radius": 0.25}, **_upload_arguments(two, views)
        )
        assert not plan.reachable and plan.refusal == "narrow_gap" and "wide" in plan.reason
        assert plan.steps == [] and plan.length is None
        with pytest.raises(ServiceError) as refused:
            client.route({"point_world": two.goal.tolist()}, scene_id=plan.scene_id, start_view=0)
    assert refused.value.status_code == 422


def test_the_command_line_prints_the_sentences_and_writes_the_plan(agent, scenes, tmp_path):
    import json

    from shared.synthetic.photo import save_photo
    from tests.test_cli import pyspatial

    two, views = scenes["reachable"]
    photos, depths = [], []
    for index, view in enumerate(views):
        photos.append(tmp_path / f"view_{index + 1}.png")
        save_photo(photos[-1], view.rgb, two.intrinsic)
        depths.append(tmp_path / f"depth_{index + 1}.npy")
        np.save(depths[-1], view.depth)
    cameras = tmp_path / "cameras.json"  # one 3x3 shared by every view
    cameras.write_text(
        json.dumps({"extrinsics": two.extrinsics.tolist(), "intrinsic": two.intrinsic.tolist()})
    )
    per_view = tmp_path / "per_view.json"
    per_view.write_text(
        json.dumps(
            {"extrinsics": two.extrinsics.tolist(), "intrinsics": [two.intrinsic.tolist()] * len(views)}
        )
    )
    pixel = goal_pixel(two)
    goal = ["--goal-pixel", f"{pixel['view']}:{pixel['u']},{pixel['v']}", "--agent-url", agent.url]
    plans = {}
    # What a shell gives for `--depths depth_*.npy` (the option's first file, then the others), the
    # repeated option, and a quoted pattern; one shared intrinsic, then one per view.
    for name, depth_arguments, camera_file in (
        ("glob", ["--depths", *map(str, depths)], cameras),
        ("repeated", [part for path in depths for part in ("--depths", str(path))], per_view),
        ("pattern", ["--depths", str(tmp_path / "depth_*.npy")], cameras),
    ):
        plan_file = tmp_path / f"{name}.json"
        done = pyspatial(
            "route",
            *map(str, photos),
            *depth_arguments,
            "--cameras",
            str(camera_file),
            "--out",
            str(plan_file),
            *goal,
            cwd=tmp_path,
        )
        assert done.returncode == 0, name + done.stdout + done.stderr
        plans[name] = json.loads(plan_file.read_text())
        assert all(sentence in done.stdout for sentence in plans[name]["sentences"])
        assert "left-positive" in done.stdout
    plan = plans["glob"]
    assert plan["reachable"] and plan["sentences"] and plan["backbone"] == "posed-rgbd"
    assert plans["repeated"]["steps"] == plan["steps"] == plans["pattern"]["steps"]
    short = pyspatial(
        "route",
        *map(str, photos),
        "--depths",
        *map(str, depths[:-1]),
        "--cameras",
        str(cameras),
        *goal,
        cwd=tmp_path,
    )
    assert short.returncode != 0
    assert f"{len(views) - 1} depth file(s) for {len(views)} photos" in short.stdout + short.stderr
    helped = pyspatial("route", "--help", cwd=tmp_path)
    assert "pyspatial-out/route/" in helped.stdout  # --out's default is shown
    bad = pyspatial(
        "route", *map(str, photos), "--goal-pixel", "2:oops", "--agent-url", agent.url, cwd=tmp_path
    )
    assert bad.returncode != 0 and "VIEW:U,V" in bad.stdout + bad.stderr


def test_how_do_i_get_there_through_solve_uses_the_same_tools(recon_and_agent, planned, scenes, llm):
    two, _ = scenes["reachable"]
    pixel = goal_pixel(two)
    program = (
        "```python\ndef program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        f"    goal = pySpatial.locate(recon, {pixel['view']}, {pixel['u']:.1f}, {pixel['v']:.1f})\n"
        "    return pySpatial.plan_route(recon, 1, goal['point'])['summary']\n```"
    )
    llm.reset()
    llm.script([program], model="coder")
    where = f"({pixel['u']:.0f}, {pixel['v']:.0f})"
    question = f"How do I get from where image 1 was taken to the spot at pixel {where} of image 4?"
    with AgentClient(recon_and_agent[1].url) as client:
        result = client.solve(question, scene_id=planned.scene_id, backbone="posed-rgbd")
    assert result.attempts[-1].error is None, result.attempts[-1].error
    assert all(sentence in result.clue.text for sentence in planned.sentences), result.clue.text


@pytest.fixture(scope="module")
def photos_only():
    """Photos the classical backbone places (its own test's arc), their true cameras and a floor goal."""
    from shared.synthetic import generate_scene, render_view
    from tests.test_classical_backbone import HEIGHT, SCENE_SEED, WIDTH, K, arc_cameras

    scene = generate_scene(SCENE_SEED)
    cameras = arc_cameras(scene)
    views = [render_view(scene, camera, K, WIDTH, HEIGHT) for camera in cameras]
    u, v = WIDTH / 2, round(0.85 * HEIGHT)
    in_camera = np.linalg.inv(K) @ [u, v, 1.0] * views[1].depth[v, int(u)]
    goal = cameras[1][:, :3].T @ (in_camera - cameras[1][:, 3])
    return cameras, views, {"pixel": {"view": 2, "u": u, "v": v}}, goal


def test_photos_with_the_camera_height_plan_in_metres(agent, photos_only):
    cameras, views, goal_pixel_of_view_2, goal = photos_only
    centres = np.array([-pose[:, :3].T @ pose[:, 3] for pose in cameras])
    height = float(centres[0, 2])  # the true start camera's height above the floor (z = 0)
    true_distance = float(np.linalg.norm(goal[:2] - centres[0, :2]))
    with AgentClient(agent.url, timeout=600) as client:
        metric = client.route(
            goal_pixel_of_view_2,
            images=[view.rgb for view in views],
            backbone="classical",
            robot={"radius": 0.2, "camera_height_m": height},
        )
        plain = client.route(goal_pixel_of_view_2, scene_id=metric.scene_id, backbone="classical")
    assert metric.units == "metres" and metric.scale_from == "camera height", metric.warnings
    assert metric.floor_residual_m is not None and metric.floor_residual_m < 0.05 * height
    # Without the height: scene units, and the two plans differ by exactly the two scales.
    assert plain.units == "scene units" and plain.scale_from == "assumed camera height"
    assert any("no metric scale" in warning for warning in plain.warnings)
    metres_per_unit = metric.straight_line / plain.straight_line
    assert metres_per_unit == pytest.approx(plain.metres_per_unit * height / 1.5, rel=1e-3)
    assert abs(metric.straight_line - true_distance) <= 0.1 * true_distance, (
        metric.straight_line,
        true_distance,
    )
    assert metric.reachable and sum(step.move for step in metric.steps) == pytest.approx(
        metric.length, abs=1e-3
    )


def test_a_metric_reconstruction_with_a_camera_height_reports_their_ratio(agent, scenes):
    two, views = scenes["reachable"]
    height = float(two.camera_height)
    with AgentClient(agent.url) as client:
        agreeing = client.route(
            {"point_world": two.goal.tolist()},
            robot={"radius": 0.25, "camera_height_m": height},
            **_upload_arguments(two, views),
        )
        off = client.route(
            {"point_world": two.goal.tolist()},
            scene_id=agreeing.scene_id,
            robot={"radius": 0.25, "camera_height_m": 1.25 * height},
        )
    assert agreeing.units == "metres" and agreeing.scale_from == "metric reconstruction"
    assert agreeing.scale_check == pytest.approx(1.0, abs=0.02) and not any(
        "ratio" in w for w in agreeing.warnings
    )
    assert off.scale_check == pytest.approx(1 / 1.25, abs=0.02) and any("ratio" in w for w in off.warnings)
    assert off.length == pytest.approx(agreeing.length, abs=1e-6)  # the metric scale stays
