"""Cheapest paths on a grid: 8-connected A* (a per-cell cost), then string pulling by line of sight.

A cell's cost is what a unit of length through it costs (1 on seen floor, more on unseen floor);
string pulling keeps a shortcut only when it costs no more than the cells it replaces, so a pulled
path does not cut across unseen floor that the search went round.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

_STEPS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]
_SQRT2 = math.sqrt(2.0)


def _octile(a: tuple[int, int], b: tuple[int, int]) -> float:
    dr, dc = abs(a[0] - b[0]), abs(a[1] - b[1])
    return max(dr, dc) + (_SQRT2 - 1.0) * min(dr, dc)


def astar(
    passable: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    cost: np.ndarray | None = None,
) -> list[tuple[int, int]] | None:
    """Cells of a cheapest 8-connected path from start to goal over ``passable``, or None.

    ``cost`` (H, W) >= 1 per unit length through a cell (a step costs its length times the mean of
    its two cells' costs); None: every cell 1, the shortest path. A diagonal step needs both cells
    beside it passable, so a path never squeezes between two obstacles that touch at a corner.
    """
    height, width = passable.shape
    weights = cost.tolist() if cost is not None else None
    if not (passable[start] and passable[goal]):
        return None
    best = {start: 0.0}
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    frontier = [(_octile(start, goal), 0.0, start)]
    closed = set()
    while frontier:
        _, cost, cell = heapq.heappop(frontier)
        if cell == goal:
            return _walk_back(parent, goal)
        if cell in closed:
            continue
        closed.add(cell)
        r, c = cell
        for dr, dc in _STEPS:
            nr, nc = r + dr, c + dc
            if not (0 <= nr < height and 0 <= nc < width) or not passable[nr, nc]:
                continue
            if dr and dc and not (passable[r, nc] and passable[nr, c]):
                continue
            step = _SQRT2 if dr and dc else 1.0
            if weights is not None:
                step *= 0.5 * (weights[r][c] + weights[nr][nc])
            new_cost = cost + step
            if new_cost < best.get((nr, nc), math.inf):
                best[(nr, nc)] = new_cost
                parent[(nr, nc)] = cell
                heapq.heappush(frontier, (new_cost + _octile((nr, nc), goal), new_cost, (nr, nc)))
    return None


def _walk_back(parent: dict, cell: tuple[int, int]) -> list[tuple[int, int]]:
    path = [cell]
    while cell in parent:
        cell = parent[cell]
        path.append(cell)
    return path[::-1]


def reachable_from(passable: np.ndarray, start: tuple[int, int]) -> np.ndarray:
    """Cells 4-connected to start over passable (a flood fill by repeated dilation)."""
    region = np.zeros_like(passable)
    if not passable[start]:
        return region
    region[start] = True
    while True:
        grown = region.copy()
        grown[1:] |= region[:-1]
        grown[:-1] |= region[1:]
        grown[:, 1:] |= region[:, :-1]
        grown[:, :-1] |= region[:, 1:]
        grown &= passable
        if np.array_equal(grown, region):
            return region
        region = grown


def segment_is_clear(passable: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """True when every cell the straight segment a -> b (cell coordinates) touches is passable."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    samples = max(int(np.ceil(np.linalg.norm(b - a) * 4)), 1)
    t = np.linspace(0.0, 1.0, samples + 1)[:, None]
    cells = np.rint(a + t * (b - a)).astype(np.int64)
    height, width = passable.shape
    if np.any(cells < 0) or np.any(cells[:, 0] >= height) or np.any(cells[:, 1] >= width):
        return False
    return bool(passable[cells[:, 0], cells[:, 1]].all())


def segment_cost(cost: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Cost of the straight segment a -> b (cell coordinates): its length times the mean cell cost."""
    length = float(np.linalg.norm(b - a))
    samples = max(int(np.ceil(length * 4)), 1)
    t = np.linspace(0.0, 1.0, samples + 1)[:, None]
    cells = np.rint(a + t * (b - a)).astype(np.int64)
    return length * float(cost[cells[:, 0], cells[:, 1]].mean())


def _path_costs(cost: np.ndarray, cells: list[np.ndarray]) -> np.ndarray:
    """Cumulative cost along the path's cells (the same per-step rule as the search)."""
    steps = [segment_cost(cost, a, b) for a, b in zip(cells[:-1], cells[1:], strict=True)]
    return np.concatenate([[0.0], np.cumsum(steps)])


def shorten(
    passable: np.ndarray, path: list[tuple[int, int]], cost: np.ndarray | None = None
) -> list[np.ndarray]:
    """Corners of the path after string pulling: from each corner, the farthest cell in sight.

    With ``cost``, a shortcut must also cost no more than the stretch of path it replaces.
    """
    cells = [np.asarray(cell, np.float64) for cell in path]
    along = _path_costs(cost, cells) if cost is not None else None
    corners = [cells[0]]
    anchor = 0
    while anchor < len(cells) - 1:
        reach = anchor + 1
        for candidate in range(len(cells) - 1, anchor, -1):
            if not segment_is_clear(passable, cells[anchor], cells[candidate]):
                continue
            if along is not None and segment_cost(cost, cells[anchor], cells[candidate]) > (
                along[candidate] - along[anchor] + 1e-6
            ):
                continue
            reach = candidate
            break
        corners.append(cells[reach])
        anchor = reach
    return corners
