"""The route planner on posed RGB-D two-room scenes, checked against their true geometry.

One reachable and one narrow-door scene are generated and rendered once per module (exact
depth and cameras); every plan is driven on the true footprints (``execute_steps``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from shared.geometry.backprojection import reconstruction_from_rgbd
from shared.navigation import Robot, estimate_floor, locate, plan_route
from shared.navigation.route import _CLOSE_HOLES_M, CELL_M
from shared.synthetic.two_rooms import (
    depths_without_floor_past_the_doorway,
    execute_steps,
    generate_two_rooms,
    past_the_doorway,
    true_shortest,
)

RADIUS = 0.25
BAND = (0.05, 0.5)


def _posed(kind: str, seed: int):
    two = generate_two_rooms(seed, kind)
    views = two.render()
    recon = reconstruction_from_rgbd(
        [v.rgb for v in views], [v.depth for v in views], two.extrinsics, [two.intrinsic] * len(views)
    )
    return two, views, recon


@pytest.fixture(scope="module")
def reachable():
    return _posed("reachable", 2)


@pytest.fixture(scope="module")
def narrow():
    return _posed("narrow_door", 3)


def test_the_floor_and_up_come_from_the_reconstruction(reachable):
    _, _, recon = reachable
    floor = estimate_floor(recon.points, recon.extrinsics)
    assert np.degrees(np.arccos(floor.up @ [0, 0, 1])) < 0.5
    assert abs(floor.offset) < 0.02
    assert np.allclose(np.cross(floor.first, floor.second), floor.up)


def test_a_reachable_goal_is_reached_without_collision_nearly_as_short_as_possible(reachable):
    two, _, recon = reachable
    plan = plan_route(recon, 0, two.goal, robot_radius=RADIUS)
    assert plan.reachable, plan.reason
    assert plan.units == "metres" and plan.turn_convention == "left-positive"
    run = execute_steps(two, plan.steps, RADIUS, BAND)
    assert not run.collided, run.first_collision
    assert np.linalg.norm(run.end - two.goal[:2]) <= 0.3
    shortest = true_shortest(
        two.solids, two.start_floor(), two.goal, RADIUS, BAND, (two.scene.room_min, two.scene.room_max)
    )
    assert plan.length <= 1.2 * shortest
    assert plan.length == pytest.approx(sum(step["move"] for step in plan.steps))
    assert plan.straight_line_distance <= plan.length + 1e-6 and plan.clearance > 0
    assert len(plan.sentences) == len(plan.steps)
    assert all(("forward" in s) and (s.startswith(("Turn", "Go"))) for s in plan.sentences)


def test_the_path_is_given_in_the_world_and_in_the_start_camera(reachable):
    two, _, recon = reachable
    plan = plan_route(recon, 0, two.goal)
    assert np.allclose(plan.path_world[0], two.start_floor(), atol=0.02)
    # The start camera is 1.5 m above the floor: below it is +1.5 along its y (OpenCV: down).
    first = plan.path_start_camera[0]
    assert first[1] == pytest.approx(1.5 * np.cos(np.radians(28.0)), abs=0.03)
    pose = recon.extrinsics[0]
    assert np.allclose(plan.path_start_camera, plan.path_world @ pose[:, :3].T + pose[:, 3])


def test_a_doorway_narrower_than_the_robot_is_refused_with_where_and_how_wide(narrow):
    two, _, recon = narrow
    plan = plan_route(recon, 0, two.goal, robot_radius=RADIUS)
    assert not plan.reachable and plan.refusal == "narrow_gap"
    assert "wide" in plan.reason and plan.steps == [] and plan.length is None
    assert abs(plan.narrowest_passage_m - (two.door[1] - two.door[0])) <= 0.1
    wide_enough = plan_route(recon, 0, two.goal, robot=Robot(radius=0.1))
    assert wide_enough.reachable, wide_enough.reason  # a small robot fits the same doorway


def _beyond_the_doorway(two):
    return past_the_doorway(two)


def _without_floor_beyond_the_doorway(two, views):
    """Posed RGB-D in which no view saw the floor just past the doorway."""
    depths = depths_without_floor_past_the_doorway(two, views)
    return reconstruction_from_rgbd(
        [v.rgb for v in views], depths, two.extrinsics, [two.intrinsic] * len(views)
    )


def _length_inside(path: np.ndarray, low: np.ndarray, high: np.ndarray, spacing: float = 0.01) -> float:
    samples = [
        a + t * (b - a)
        for a, b in zip(path[:-1], path[1:], strict=True)
        for t in np.arange(0.0, 1.0, spacing / max(np.linalg.norm(b - a), 1e-9))
    ]
    inside = [np.all((p[:2] >= low) & (p[:2] <= high)) for p in samples]
    return float(np.count_nonzero(inside) * spacing)


def test_floor_unseen_past_the_doorway_is_crossed_and_said(reachable):
    two, views, _ = reachable
    recon = _without_floor_beyond_the_doorway(two, views)
    plan = plan_route(recon, 0, two.goal, robot_radius=RADIUS)
    assert plan.reachable, plan.reason
    run = execute_steps(two, plan.steps, RADIUS, BAND)
    assert not run.collided and np.linalg.norm(run.end - two.goal[:2]) <= 0.3
    # Every way into room B crosses the blanked box; the planner's unseen metres are that crossing,
    # give or take the closing of small holes at the box's two sides and the sampling.
    low, high = _beyond_the_doorway(two)
    crossing = _length_inside(plan.path_world, low, high)
    assert crossing >= high[0] - low[0] - 0.02
    slack = 2 * _CLOSE_HOLES_M + CELL_M
    assert crossing - slack <= plan.unseen_m <= crossing + CELL_M, (plan.unseen_m, crossing)
    assert plan.unseen_m == pytest.approx(sum(step["unseen_m"] for step in plan.steps), abs=1e-3)
    assert plan.unseen_m == pytest.approx(sum(s["length"] for s in plan.unseen_stretches), abs=1e-3)
    for stretch in plan.unseen_stretches:
        step = plan.steps[stretch["step"] - 1]
        assert step["unseen_m"] > 0 and "floor no photo shows" in plan.sentences[stretch["step"] - 1]
        for end in (stretch["start_world"], stretch["end_world"]):
            assert np.all(np.array(end[:2]) >= low - slack) and np.all(np.array(end[:2]) <= high + slack)
    said = [s for s, step in zip(plan.sentences, plan.steps, strict=True) if step["unseen_m"] > 0]
    assert said and all("go slowly and look again" in s for s in said)
    assert not any(
        "no photo" in s for s, step in zip(plan.sentences, plan.steps, strict=True) if not step["unseen_m"]
    )


def test_a_narrow_doorway_is_measured_between_its_seen_jambs_even_with_the_floor_past_it_unseen(narrow):
    two, views, recon = narrow
    door = two.door[1] - two.door[0]
    for reconstruction in (recon, _without_floor_beyond_the_doorway(two, views)):
        plan = plan_route(reconstruction, 0, two.goal, robot_radius=RADIUS)
        assert not plan.reachable and plan.refusal == "narrow_gap", plan.reason
        assert abs(plan.narrowest_passage_m - door) <= 0.1, (plan.narrowest_passage_m, door)
        assert f"{plan.narrowest_passage_m:.2f} m wide" in plan.reason
        where = [float(part) for part in plan.reason.split("near (")[1].split(")")[0].split(",")]
        assert abs(where[0] - two.divider_x) <= 0.3 and two.door[0] - 0.1 <= where[1] <= two.door[1] + 0.1


def test_locate_reads_depth_or_points_and_says_when_nothing_is_there(reachable):
    two, views, recon = reachable
    v, u = 200, 160
    z = views[2].depth[v, u]
    found = locate(recon, 2, u, v)
    assert found.source == "depth"
    in_camera = recon.extrinsics[2][:, :3] @ found.point + recon.extrinsics[2][:, 3]
    assert in_camera[2] == pytest.approx(z, abs=1e-4)
    no_depth = dataclasses.replace(recon, depths=None, intrinsics_source=None, view_confidence=None)
    by_points = locate(no_depth, 2, u, v)
    assert by_points.source == "points" and np.linalg.norm(by_points.point - found.point) < 0.1
    with pytest.raises(ValueError, match="outside"):
        locate(recon, 2, 320, 10)
    holes = [d.copy() for d in recon.depths]
    holes[2][:] = 0
    empty = dataclasses.replace(recon, depths=holes, intrinsics_source=None, view_confidence=None)
    assert locate(empty, 2, u, v).point is None and "no depth" in locate(empty, 2, u, v).reason
    # An estimated depth map's hole falls back to the points; with the points gone too, nothing is there.
    estimated = dataclasses.replace(empty, backbone="classical", intrinsics_source=None, view_confidence=None)
    assert locate(estimated, 2, u, v).source == "points"
    bare = dataclasses.replace(
        estimated,
        points=np.zeros((0, 3)),
        colors=np.zeros((0, 3)),
        intrinsics_source=None,
        view_confidence=None,
    )
    missing = locate(bare, 2, u, v)
    assert (
        missing.point is None
        and "no depth" in missing.reason
        and "nothing is reconstructed" in missing.reason
    )


def test_a_reconstruction_without_scale_plans_in_scene_units(reachable):
    two, _, recon = reachable
    half = dataclasses.replace(
        recon,
        points=recon.points * 0.5,
        units="relative",
        intrinsics_source=None,
        view_confidence=None,
        extrinsics=np.concatenate([recon.extrinsics[:, :, :3], recon.extrinsics[:, :, 3:] * 0.5], axis=2),
    )
    metric = plan_route(recon, 0, two.goal)
    scaled = plan_route(half, 0, two.goal * 0.5)
    assert scaled.reachable and scaled.units == "scene units" and "scale" in scaled.warnings[0]
    assert scaled.length == pytest.approx(0.5 * metric.length, rel=0.1)
    assert "scene units" in scaled.sentences[-1]


def test_a_goal_inside_a_closed_pen_is_refused_as_enclosed():
    two, _, recon = _posed("ring", 23005)  # bench.route's scene 5
    plan = plan_route(recon, 0, two.goal, robot_radius=RADIUS)
    assert not plan.reachable and plan.refusal == "enclosed" and "enclosed" in plan.reason
