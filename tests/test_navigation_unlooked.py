"""Space no view looked into: crossed when nothing else joins start and goal, and said; seen walls
continued into it; passages measured between seen points on both sides.

The grid-level tests build small grids by hand; the scene tests use ``bench.route``'s tuning seed
(23) two-room captures, rendered with exact depth and cameras and driven on the true geometry.
"""

from __future__ import annotations

import numpy as np
import pytest

from bench.route import doorway_coverage, doorway_in_photo, seen_floor, unseen_along
from shared.navigation import plan_route
from shared.navigation.grid import Grid
from shared.navigation.passage import _closest_pair
from shared.navigation.walls import continued_walls
from shared.synthetic.two_rooms import WALL, execute_steps
from tests.support.route_scenes import tuning_capture

RADIUS = 0.25
BAND = (0.05, 0.5)
CELL = 0.05  # metres: the grids below are metric, one scene unit a metre


def _grid(shape=(80, 40)) -> Grid:
    """Everything looked into and seen free; tests then place walls and hidden space."""
    grid = Grid(origin=np.zeros(2), cell=CELL, occupied=np.zeros(shape, bool), free=np.ones(shape, bool))
    grid.looked = np.ones(shape, bool)
    grid.tall = np.zeros(shape, bool)
    return grid


def _wall(grid: Grid, column: int, rows: range) -> None:
    grid.occupied[rows.start : rows.stop, column] = True
    grid.tall[rows.start : rows.stop, column] = True
    grid.free[rows.start : rows.stop, column] = False


def _hide(grid: Grid, rows: range, columns: range) -> None:
    grid.free[rows.start : rows.stop, columns.start : columns.stop] = False
    grid.looked[rows.start : rows.stop, columns.start : columns.stop] = False


def test_a_seen_wall_runs_on_through_hidden_space_until_sight_crosses_its_line():
    grid = _grid()
    _wall(grid, 20, range(5, 35))  # 1.5 m of wall seen
    _hide(grid, range(35, 60), range(10, 30))  # then nothing looked into; below, open floor again
    walls = continued_walls(grid, grid.tall, 1.0, 2 * RADIUS)
    assert walls[35:60, 20].all()  # its line, across all the hidden space
    assert not walls[60:, :].any() and not walls[:35, :].any()  # not past where sight crossed it
    assert walls.sum() <= 2 * 25  # a line, not the hidden block
    assert not (walls & ~grid.hidden).any()


def test_a_hidden_gap_between_two_seen_stretches_of_one_wall_stays_open():
    grid = _grid()
    _wall(grid, 20, range(5, 30))
    _wall(grid, 20, range(50, 75))
    _hide(grid, range(30, 50), range(10, 30))  # a doorway's width, its floor and its line unseen
    assert not continued_walls(grid, grid.tall, 1.0, 2 * RADIUS).any()


def test_a_doorway_between_seen_jambs_stays_open_though_a_jamb_face_and_a_corner_are_near():
    # The wall's room-A face runs along column 10 below and above a doorway; its far side (room B)
    # is hidden. The near jamb's end face (row 30) and a meeting wall (row 2) are within a line
    # fit's reach: a fit on all of them is tilted, and a tilted line misses the far part of the wall.
    grid = _grid()
    _hide(grid, range(0, 80), range(11, 40))
    _wall(grid, 10, range(0, 31))
    _wall(grid, 10, range(52, 80))
    grid.occupied[30, 10:13] = grid.tall[30, 10:13] = True  # the near jamb's end face
    grid.occupied[2, 2:10] = grid.tall[2, 2:10] = True  # a meeting wall's last cells
    _hide(grid, range(31, 52), range(10, 11))  # the doorway, not seen from room A along the wall
    walls = continued_walls(grid, grid.tall, 1.0, 2 * RADIUS)
    assert not walls[32:51, 9:14].any()  # (the cells at the jambs' corners may be the wall's hidden face)
    # the same wall with nothing seen beyond the hidden stretch is continued across it
    grid.occupied[52:, 10] = grid.tall[52:, 10] = False
    _hide(grid, range(52, 80), range(10, 11))
    assert continued_walls(grid, grid.tall, 1.0, 2 * RADIUS)[31:52, 10].all()


def test_no_wall_is_guessed_where_none_or_only_a_short_run_was_seen():
    grid = _grid()
    _hide(grid, range(35, 60), range(10, 30))
    assert not continued_walls(grid, grid.tall, 1.0, 2 * RADIUS).any()
    _wall(grid, 20, range(28, 35))  # 0.35 m: a post or a shelf's side, not a wall's line
    assert not continued_walls(grid, grid.tall, 1.0, 2 * RADIUS).any()


def test_a_crossing_narrower_than_the_robot_does_not_end_the_wall():
    grid = _grid()
    _wall(grid, 20, range(5, 35))
    _hide(grid, range(35, 75), range(10, 30))
    grid.free[40:44, 10:30] = grid.looked[40:44, 10:30] = True  # 0.2 m that sight crossed
    walls = continued_walls(grid, grid.tall, 1.0, 2 * RADIUS)
    assert walls[35:40, 20].all() and walls[44:75, 20].all()


def test_a_passage_off_the_doorway_line_is_still_measured_jamb_to_jamb():
    door = (1.0, 1.4)
    jambs = [np.array([[x, y] for x in np.linspace(0.0, 0.12, 7)]) for y in door]
    faces = [  # both faces of the wall on either side of the doorway
        np.array([[x, y] for y in np.linspace(door[0] - 1.0, door[0], 21)]) for x in (0.0, 0.12)
    ] + [np.array([[x, y] for y in np.linspace(door[1], door[1] + 1.0, 21)]) for x in (0.0, 0.12)]
    points = np.concatenate([*jambs, *faces])
    # the tight spots of a way through it: on the doorway's line, and a little before and past it
    for at in (np.array([0.06, 1.2]), np.array([0.2, 1.15]), np.array([-0.08, 1.25])):
        pair = _closest_pair(points, at, reach=0.5)
        assert pair is not None
        assert abs(np.linalg.norm(pair[0] - pair[1]) - (door[1] - door[0])) <= 0.05, (at, pair)
    assert _closest_pair(points, np.array([0.06, 1.2]), reach=0.1) is None  # no seen point so close
    # with the way's direction (through the doorway, along x) the jambs are still the pair
    for at in (np.array([0.06, 1.2]), np.array([0.2, 1.15])):
        pair = _closest_pair(points, at, reach=0.5, along=np.array([1.0, 0.0]))
        assert pair is not None and abs(np.linalg.norm(pair[0] - pair[1]) - (door[1] - door[0])) <= 0.05


def test_a_way_that_hugs_one_wall_has_no_passage_there():
    # a way running along a wall's face, close to it: the nearest seen points behind and ahead on
    # that face are not the two sides of a passage
    face = np.array([[0.12, y] for y in np.linspace(0.0, 2.0, 41)])
    at, along = np.array([0.15, 1.02]), np.array([0.0, 1.0])
    assert _closest_pair(face, at, reach=0.5, along=along) is None
    across = np.concatenate([face, [[0.6, 1.0]]])  # something on the other side of the way
    pair = _closest_pair(across, at, reach=0.6, along=along)
    assert pair is not None and pair[0][0] < at[0] < pair[1][0]


def test_a_doorway_no_view_looked_through_is_crossed_and_the_plan_says_so():
    two, views, recon = tuning_capture(19, "reachable")  # bench.route seed 23 scene 19: coverage none
    assert two.coverage == "none"
    plan = plan_route(recon, 0, two.goal, robot_radius=RADIUS)
    assert plan.reachable, plan.reason
    run = execute_steps(two, plan.steps, RADIUS, BAND)
    assert not run.collided and np.linalg.norm(run.end - two.goal[:2]) <= 0.3
    assert any("no view looked into" in warning for warning in plan.warnings)
    # every metre the independent check finds unseen is reported, give or take hole closing
    assert plan.unseen_m >= unseen_along(two, views, plan.path_world) - 0.2
    assert plan.unseen_stretches and all(
        "no photo shows" in plan.sentences[s["step"] - 1] for s in plan.unseen_stretches
    )


@pytest.mark.parametrize(
    "index",
    [
        22,  # the dividing wall's ends were not looked at: it is continued, not crossed
        58,  # the start's surroundings join the doorway only across unlooked floor
    ],
)
def test_a_narrow_doorway_beside_unlooked_space_is_still_refused_with_its_width(index):
    two, _, recon = tuning_capture(index, "narrow_door")
    plan = plan_route(recon, 0, two.goal, robot_radius=RADIUS)
    assert not plan.reachable and plan.refusal == "narrow_gap", plan.reason
    assert plan.narrowest_passage_m == pytest.approx(two.door[1] - two.door[0], abs=0.1)


def test_a_doorway_in_a_photo_with_the_floor_past_it_in_none_is_crossed_and_said():
    two, views, recon = tuning_capture(2, "reachable")  # bench.route seed 23 scene 2: coverage doorway
    assert two.coverage == "doorway"
    # what the capture shows, measured on the rendered depth: both jambs, and none of the floor within
    # 1.2 m past the doorway (a metre wider than it each side)
    assert doorway_in_photo(two, views)
    assert doorway_coverage(two, views) == 0.0
    xs = np.arange(two.divider_x + WALL / 2 + 0.025, two.divider_x + WALL / 2 + 1.2, 0.05)
    ys = np.arange(two.door[0] - 1.0, two.door[1] + 1.0, 0.05)
    assert not seen_floor(two, views, np.array([[x, y, 0.0] for x in xs for y in ys])).any()
    plan = plan_route(recon, 0, two.goal, robot_radius=RADIUS)
    assert plan.reachable, plan.reason
    run = execute_steps(two, plan.steps, RADIUS, BAND)
    assert not run.collided and np.linalg.norm(run.end - two.goal[:2]) <= 0.3
    crossing = unseen_along(two, views, plan.path_world)
    assert crossing >= 0.2  # past the doorway, at least
    assert plan.unseen_m > 0 and plan.unseen_m >= crossing - 0.2
    assert any("no view saw" in warning for warning in plan.warnings)
