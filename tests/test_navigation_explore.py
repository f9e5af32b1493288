"""Where to look next when no photo shows a way (``shared/navigation/explore.py``), and the closed
loop that follows it.

The grid tests build a small metric grid by hand (one scene unit a metre); the scene tests use
``bench.route``'s tuning seed (23) two-room captures whose doorway is in no photo, rendered with
exact depth and cameras, driven on the true geometry. Expectations come from each scene's own
truth (the doorway's width, the true footprints) and from the look the plan returns.
"""

from __future__ import annotations

import numpy as np
import pytest

from bench.route import doorway_in_photo, seen_floor
from bench.route_loop import closed_loop
from shared.navigation import Robot, plan_route
from shared.navigation.explore import LOOK_FROM_M, next_look
from shared.navigation.grid import Grid, dilate
from shared.synthetic.two_rooms import disc_collides, drive, footprints
from tests.support.route_scenes import tuning_capture

RADIUS = 0.25
BAND = (0.05, 0.5)
CELL = 0.05
RADIUS_CELLS = (RADIUS + 0.05) / CELL


def _walled_grid(gap_rows: range | None) -> Grid:
    """Two rooms side by side (columns < 60 and > 60), all looked into except a band along the
    dividing wall (rows 70-110) that no view reached; ``gap_rows``: where that band's wall is open."""
    shape = (140, 120)
    grid = Grid(origin=np.zeros(2), cell=CELL, occupied=np.zeros(shape, bool), free=np.ones(shape, bool))
    grid.looked = np.ones(shape, bool)
    grid.tall = np.zeros(shape, bool)
    band = (slice(70, 110), slice(55, 66))
    grid.free[band] = False
    grid.looked[band] = False
    wall = np.zeros(shape, bool)
    wall[:, 60] = True
    wall[band] = False  # what no view reached is not known to be wall
    if gap_rows is None:
        wall[70:110, 60] = True  # (a test where the wall is seen whole)
        grid.looked[70:110, 60] = True
    grid.occupied |= wall
    grid.free &= ~wall
    return grid


def _look(grid: Grid, start=(20, 20), goal=(20, 100)):
    driveable = ~dilate(grid.blocked, RADIUS_CELLS)
    cost = np.where(grid.unseen, 1.5, 1.0)
    start_plane = grid.to_plane(np.array([start]))[0]
    return next_look(
        grid, None, driveable, cost, start, goal, start_plane, 0.0, RADIUS_CELLS, 1.0, 1.0, "metres"
    ), driveable


def test_the_look_faces_where_the_likeliest_way_enters_unlooked_space_from_driveable_floor():
    grid = _walled_grid(gap_rows=range(70, 110))
    look, driveable = _look(grid)
    assert look is not None
    face = grid.to_cell(look.face_plane)[0]
    assert grid.hidden[face[0], face[1]]  # where no view looked
    stand = grid.to_cell(look.stand_plane)[0]
    assert driveable[stand[0], stand[1]]
    # about LOOK_FROM_M back from it when the driveable floor allows, never nearer than it in sight
    distance = float(np.linalg.norm(look.stand_plane - look.face_plane))
    assert LOOK_FROM_M - 2 * CELL <= distance <= LOOK_FROM_M + 4 * CELL
    # the steps, driven from the start, end there facing the point; every sample on driveable floor
    samples, end, heading, _ = drive(
        grid.to_plane(np.array([[20, 20]]))[0],
        0.0,
        [(s["turn_degrees"], s["move"]) for s in look.steps],
        CELL / 2,
    )
    assert np.linalg.norm(end - look.stand_plane) < 1e-3  # the steps are rounded
    towards = look.face_plane - end
    off = (np.arctan2(towards[1], towards[0]) - heading + np.pi) % (2 * np.pi) - np.pi
    assert abs(np.degrees(off)) < 0.5
    cells = grid.to_cell(samples)
    assert driveable[cells[:, 0], cells[:, 1]].all()
    assert look.steps[-1]["move"] == 0.0 and len(look.sentences) == len(look.steps)


def test_no_look_is_offered_when_seen_obstacles_close_every_way():
    grid = _walled_grid(gap_rows=None)
    assert not grid.hidden[:, 60].any()  # the premise: the dividing wall is seen whole
    look, _ = _look(grid)
    assert look is None


def _tuning(index: int, kind: str):
    two, views, recon = tuning_capture(index, kind)
    return two, views, plan_route(recon, 0, two.goal, robot=Robot(radius=RADIUS))


@pytest.fixture(scope="module")
def doorway_in_no_photo():
    two, views, plan = _tuning(1, "reachable")  # bench.route seed 23 scene 1: coverage none
    assert two.coverage == "none" and not doorway_in_photo(two, views)
    return two, views, plan


def test_a_doorway_in_no_photo_is_refused_with_a_look_that_the_true_room_lets_the_robot_take(
    doorway_in_no_photo,
):
    two, views, plan = doorway_in_no_photo
    assert not plan.reachable and plan.refusal == "unseen_space", plan.reason
    look = plan.look_next
    assert look is not None and look["sentences"]
    face = np.array(look["face_world"])
    assert not seen_floor(two, views, np.array([[face[0], face[1], 0.0]]))[0]  # no photo shows it
    forward = two.extrinsics[0][2, :2]
    samples, end, heading, _ = drive(
        two.start_floor()[:2],
        float(np.arctan2(forward[1], forward[0])),
        [(s["turn_degrees"], s["move"]) for s in look["steps"]],
        0.02,
    )
    assert np.linalg.norm(end - np.array(look["stand_world"])[:2]) < 0.01
    towards = face[:2] - end
    off = (np.arctan2(towards[1], towards[0]) - heading + np.pi) % (2 * np.pi) - np.pi
    assert abs(np.degrees(off)) < 1.0
    assert not disc_collides(samples, footprints(two.solids, BAND), RADIUS).any()


def test_the_closed_loop_takes_that_look_and_reaches_the_goal(doorway_in_no_photo):
    two, views, plan = doorway_in_no_photo
    run = closed_loop(two, views, plan, Robot(radius=RADIUS), two.goal, max_looks=4, band=BAND)
    assert run.looks and np.linalg.norm(run.looks[0] - np.array(plan.look_next["stand_world"])[:2]) < 0.01
    assert not run.collided and not run.refused
    assert np.linalg.norm(run.end - two.goal[:2]) <= 0.3
    # each replan is kept with the views it was made on: the looks so far, newest first, then the capture's
    assert len(run.replans) == len(run.looks)
    for number, (_, seen) in enumerate(run.replans, 1):
        assert len(seen) == len(views) + number and seen[number:] == list(views)
    assert run.replans[-1][0] is run.last_plan
    # without looks the refusal stands: the robot does not move
    still = closed_loop(two, views, plan, Robot(radius=RADIUS), two.goal, max_looks=0, band=BAND)
    assert still.refused and still.length == 0.0


def test_a_narrow_doorway_in_no_photo_is_measured_once_the_robot_has_looked():
    two, views, plan = _tuning(10, "narrow_door")  # seed 23 scene 10: coverage none
    assert not doorway_in_photo(two, views)
    assert plan.refusal == "unseen_space" and plan.look_next is not None
    run = closed_loop(two, views, plan, Robot(radius=RADIUS), two.goal, max_looks=4, band=BAND)
    assert run.refused and not run.collided and run.looks
    last = run.last_plan
    assert last.refusal == "narrow_gap", last.reason
    assert last.narrowest_passage_m == pytest.approx(two.door[1] - two.door[0], abs=0.1)


def test_the_route_response_carries_the_look(doorway_in_no_photo):
    from services.agent.route_plan import _response

    _, _, plan = doorway_in_no_photo
    response = _response(plan, "scene", "posed_rgbd", None)
    assert response.refusal == "unseen_space" and response.look_next is not None
    assert response.look_next.stand_world == plan.look_next["stand_world"]
    assert [s.model_dump() for s in response.look_next.steps] == plan.look_next["steps"]
    body = response.model_dump(mode="json")
    assert body["look_next"]["sentences"] == plan.look_next["sentences"]


def test_a_narrow_doorway_no_view_looked_between_is_measured_when_nothing_unlooked_opens_a_way():
    # seed 23 scene 88: a narrow doorway whose jambs a photo shows, with no view looking between them
    two, views, plan = _tuning(88, "narrow_door")
    assert doorway_in_photo(two, views)
    assert plan.refusal == "narrow_gap" and plan.look_next is None, plan.reason
    assert plan.narrowest_passage_m == pytest.approx(two.door[1] - two.door[0], abs=0.1)


def test_a_goal_no_view_looked_at_is_refused_with_a_look_that_finds_it():
    two, views, plan = _tuning(272, "reachable")  # seed 23 scene 272: the goal's floor in no photo
    assert plan.refusal == "goal_unseen" and plan.look_next is not None, plan.reason
    face = np.array(plan.look_next["face_world"])
    assert not seen_floor(two, views, np.array([[face[0], face[1], 0.0]]))[0]
    run = closed_loop(two, views, plan, Robot(radius=RADIUS), two.goal, max_looks=4, band=BAND)
    assert run.looks and not run.collided and not run.refused
    assert np.linalg.norm(run.end - two.goal[:2]) <= 0.3
