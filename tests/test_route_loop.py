"""The route bench's closed loop: the robot stops where its plan crosses unseen floor, looks from
its own camera there, replans, and every metre it drove is checked against the true geometry.

The scene is ``bench.route``'s tuning seed (23) scene 21, a ``doorway`` capture whose first plan
crosses floor no photo shows; expectations are derived from that plan and the run's own trace.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from bench.route_loop import _stretch_arcs, closed_loop, next_stop
from shared.navigation import Robot, plan_route
from shared.synthetic.two_rooms import disc_collides, execute_steps, footprints
from tests.support.route_scenes import tuning_capture

RADIUS = 0.25
BAND = (0.05, 0.5)
STEP_M = 0.02


@pytest.fixture(scope="module")
def capture():
    two, views, recon = tuning_capture(21, "reachable")
    robot = Robot(radius=RADIUS)
    return two, views, plan_route(recon, 0, two.goal, robot=robot), robot


def _start_pose(two):
    forward = two.extrinsics[0][2, :2]
    return two.start_floor()[:2], float(np.arctan2(forward[1], forward[0]))


def _point_along(plan, position, heading, distance):
    """Where the plan's steps, driven from the pose, are after ``distance`` metres."""
    for step in plan.steps:
        heading += np.radians(step["turn_degrees"])
        if step["move"] >= distance:
            return position + distance * np.array([np.cos(heading), np.sin(heading)])
        position = position + step["move"] * np.array([np.cos(heading), np.sin(heading)])
        distance -= step["move"]
    return position


def _box(xy, half=0.08, height=0.4):
    corners = itertools.product((-half, half), (-half, half), (0.0, height))
    return np.array([[xy[0] + dx, xy[1] + dy, z] for dx, dy, z in corners])


def test_the_robot_looks_again_where_its_plan_first_crosses_unseen_floor(capture):
    two, views, plan, robot = capture
    assert plan.reachable and plan.unseen_stretches  # the premise: a plan over floor no photo shows
    position, heading = _start_pose(two)
    stop = next_stop(_stretch_arcs(plan, position, heading))
    assert stop is not None and 0 < stop < plan.length
    run = closed_loop(two, views, plan, robot, two.goal, max_looks=4, band=BAND, step_m=STEP_M)
    assert run.looks, "no new look where the plan crossed unseen floor"
    assert np.linalg.norm(run.looks[0] - _point_along(plan, position, heading, stop)) < 0.01
    # the look's own frame starts the replan: a plan from where the robot stood (the last one)
    assert np.linalg.norm(run.last_plan.start_world[:2] - run.looks[-1]) < 0.05
    # without looks the loop is the single-shot execution
    once = closed_loop(two, views, plan, robot, two.goal, max_looks=0, band=BAND, step_m=STEP_M)
    single = execute_steps(two, plan.steps, RADIUS, BAND)
    assert not once.looks and once.collided == single.collided
    assert np.allclose(once.end, single.end, atol=1e-6)


def test_the_collision_check_covers_every_driven_segment(capture):
    two, views, plan, robot = capture
    run = closed_loop(two, views, plan, robot, two.goal, max_looks=4, band=BAND, step_m=STEP_M)
    trace = run.trace
    assert np.allclose(trace[0], two.start_floor()[:2]) and np.allclose(trace[-1], run.end)
    gaps = np.linalg.norm(np.diff(trace, axis=0), axis=1)
    assert gaps.max() <= STEP_M + 1e-9  # no part of the path, before or after a look, is skipped
    assert abs(gaps.sum() - run.length) < 0.02 * max(run.length, 1.0) + 1e-6
    for look in run.looks:  # the stretches driven before each look are in the trace
        assert np.linalg.norm(trace - look, axis=1).min() < 1e-6
    assert run.collided == bool(disc_collides(trace, footprints(two.solids, BAND), RADIUS).any())

    # something no photo shows, standing on the part driven before the first look: a collision
    position, heading = _start_pose(two)
    before = _point_along(plan, position, heading, 0.5 * next_stop(_stretch_arcs(plan, position, heading)))
    hidden_early = dataclasses.replace(two, solids=[*two.solids, _box(before)])
    early = closed_loop(hidden_early, views, plan, robot, two.goal, max_looks=4, band=BAND, step_m=STEP_M)
    assert early.collided and not early.looks  # it stops there, before looking

    # ... and on the last leg, driven after the looks
    if not run.collided:
        after = trace[int(0.9 * (len(trace) - 1))]
        hidden_late = dataclasses.replace(two, solids=[*two.solids, _box(after)])
        late = closed_loop(hidden_late, views, plan, robot, two.goal, max_looks=4, band=BAND, step_m=STEP_M)
        assert late.collided
