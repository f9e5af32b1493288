"""The narrowest passage between start and goal, measured on the seen obstacles.

The widest way through the seen obstacles is found by growing the obstacles until start and goal
come apart (a bisection on the growth radius); its tightest cell is the passage. The width is then
measured on the obstacle *points* around it, the closest pair on opposite sides (the two jambs of
a doorway), so it is what a tape measure between the seen surfaces would read, not a count of
cells and not the edge of the seen floor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.navigation.grid import Grid, dilate
from shared.navigation.search import astar, reachable_from

_BISECTIONS = 8


@dataclass(frozen=True)
class Passage:
    where: np.ndarray  # (2,) floor coordinates of the tightest point of the widest way
    width: float  # scene units between the seen obstacles on both sides
    sides: tuple[np.ndarray, np.ndarray] | None  # the two obstacle points the width is measured on


def _connected(occupied: np.ndarray, radius_cells: float, start, goal) -> bool:
    passable = ~dilate(occupied, radius_cells)
    return bool(passable[start] and passable[goal] and reachable_from(passable, start)[goal])


def _widest_radius(occupied: np.ndarray, start, goal, most: float) -> float:
    """The largest obstacle growth (cells) that still leaves start and goal joined (0 when joined)."""
    low, high = 0.0, most
    for _ in range(_BISECTIONS):
        middle = 0.5 * (low + high)
        if _connected(occupied, middle, start, goal):
            low = middle
        else:
            high = middle
    return low


def _closest_pair(
    points: np.ndarray, at: np.ndarray, reach: float, along: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """The closest obstacle points on the two sides of ``at``, or None.

    One side holds the point nearest ``at``; the other, the points beyond ``at`` from it (a doorway's
    two jambs). Both must lie within ``reach`` of ``at``: a side that no seen point bounds so close
    is bounded by space no view looked into, and the passage has no width to tell. (Pulling the pair
    together further would slide both onto one jamb when ``at`` is off the doorway's line; among the
    tight spots of the way, the one between the jambs gives the smallest width.)

    ``along``: the way's direction at ``at``; the two points must then lie on either side of it (a
    way that hugs one wall has two near points on that wall, behind and ahead, and no passage).
    """
    if len(points) < 2:
        return None
    first = points[int(np.argmin(np.linalg.norm(points - at, axis=1)))]
    opposite = (points - at) @ (first - at) < 0
    if along is not None:
        side = np.sign(_cross(along, first - at))
        if side == 0:
            return None
        opposite &= np.sign(_cross(along, points - at)) == -side
    if not opposite.any():
        return None
    other_side = points[opposite]
    second = other_side[int(np.argmin(np.linalg.norm(other_side - at, axis=1)))]
    if max(np.linalg.norm(first - at), np.linalg.norm(second - at)) > reach:
        return None
    return first, second


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z of the 2D cross product a x b (b may be (N, 2)): its sign says on which side of a b lies."""
    return a[0] * b[..., 1] - a[1] * b[..., 0]


def narrowest_passage(
    grid: Grid,
    start: tuple[int, int],
    goal: tuple[int, int],
    most_cells: float,
    blocked: np.ndarray | None = None,
) -> Passage | None:
    """The passage that limits the widest way from start to goal; None when no way exists at all.

    ``blocked``: what closes the way (default ``grid.blocked``: seen obstacles, unlooked space, edge).
    """
    blocked = grid.blocked if blocked is None else blocked
    if not _connected(blocked, 0.0, start, goal):
        return None
    radius = _widest_radius(blocked, start, goal, most_cells)
    cells = astar(~dilate(blocked, radius), start, goal)
    if cells is None:  # the bisection's lower end is always joined; guard the 4- vs 8-connected edge
        cells = astar(~blocked, start, goal)
    plane = grid.to_plane(np.array(cells))
    centres = grid.to_plane(np.argwhere(blocked))
    distance = np.array([np.linalg.norm(centres - point, axis=1).min() for point in plane])
    # Every cell as tight as the tightest (within a cell) may be the passage; one that is tight on
    # one side only (the path hugging a corner) is not a passage, so it needs obstacles on both sides.
    passages = []
    for index in np.flatnonzero(distance <= distance.min() + grid.cell):
        where = plane[index]
        reach = distance[index] + 2 * grid.cell
        near = grid.obstacle_points[np.linalg.norm(grid.obstacle_points - where, axis=1) <= 2 * reach]
        along = plane[min(index + 1, len(plane) - 1)] - plane[max(index - 1, 0)]
        pair = _closest_pair(near, where, reach, along if np.any(along) else None)
        if pair is not None:
            passages.append(Passage(where, float(np.linalg.norm(pair[0] - pair[1])), pair))
    if passages:
        return min(passages, key=lambda passage: passage.width)
    tightest = int(np.argmin(distance))  # no seen points on both sides (the map's edge): the cells' gap
    return Passage(plane[tightest], max(2 * distance[tightest] - grid.cell, 0.0), None)


def looked_through(grid: Grid, passage: Passage) -> bool:
    """Whether some line of sight passed between the passage's two sides.

    A gap between two seen points whose floor between them (a cell in from each side) no view looked
    into at all is not a measured passage: the points may be one surface's two seen parts around an
    occluded corner (a wall meeting another), and what lies between is unknown, not a slot.
    """
    if passage.sides is None or grid.looked is None:
        return True
    a, b = passage.sides
    length = float(np.linalg.norm(b - a))
    if length < 3 * grid.cell:  # no cells between the sides' own to judge by
        return True
    along = np.arange(grid.cell, length - grid.cell + 1e-9, 0.5 * grid.cell) / length
    cells = grid.to_cell(a + along[:, None] * (b - a))
    cells = cells[grid.inside(cells)]
    return bool(len(cells) == 0 or (~grid.hidden[cells[:, 0], cells[:, 1]]).any())
