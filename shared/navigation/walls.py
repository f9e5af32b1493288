"""Seen walls continued where no view looked: a wall seen to run on is assumed to run on.

Space that no line of sight reached (``Grid.hidden``) may be crossed when nothing else joins the
start to the goal, but not across the line of a wall that was seen running into it: the part of a
wall no view looked at is still a wall. A wall here is a tall straight run of occupied cells (seen
above ``tall`` scene units, higher than furniture the robot drives past). From each of its cells
that borders hidden space, the run's line (a local principal axis) is followed through the seen
wall and on through hidden cells, which are marked, until a line of sight is seen to cross it (the
wall ended there: a ray passed where it would stand) or the map's edge. A wall no view saw at
all is not guessed at.
"""

from __future__ import annotations

import numpy as np

from shared.navigation.grid import Grid, dilate

_NEIGHBOURHOOD_M = 1.2  # the run's line is fitted on the tall cells this close
_MIN_RUN_M = 1.1  # a shorter run (a post, a bookshelf's front) gives no line to follow
_SIDE_CELLS = 3  # a line of sight that crossed the wall's line passed over cells this far either side
_RESUMES_M = 0.4  # seen standing this far along the line after a gap: the same wall goes on there
# ... within this many cells across the line: a line fitted near a jamb (its end face seen too) is
# tilted a few degrees, and over a doorway's width it drifts off the wall's far part by a cell or two
_RESUMES_ACROSS_CELLS = 2
_ON_LINE_CELLS = 1.5  # a run's cells lie this close to its line (the refit keeps only those)
_MAX_THICKNESS_RATIO = 0.2  # across the line / along it (standard deviations): straight enough


def continued_walls(grid: Grid, tall: np.ndarray, per_metre: float, min_gap: float) -> np.ndarray:
    """(H, W) bool: hidden cells on the line of a seen wall that runs into them.

    ``min_gap`` (scene units, the robot's width): a crossing narrower than this does not end the wall.
    """
    hidden = grid.hidden
    out = np.zeros(grid.shape, bool)
    if not hidden.any() or not tall.any():
        return out
    tall_cells = np.argwhere(tall)
    reach = _NEIGHBOURHOOD_M * per_metre / grid.cell
    # the tall cells near hidden space (a wall's last metres may be seen only low, below ``tall``)
    borders = np.argwhere(tall & dilate(hidden, 0.5 * reach))
    longest = float(np.hypot(*grid.shape))
    along = np.arange(0.0, longest, 0.5)
    per_cell = per_metre / grid.cell
    for cell in borders:
        near = tall_cells[np.linalg.norm(tall_cells - cell, axis=1) <= reach]
        direction = _line_direction(near, _MIN_RUN_M * per_metre / grid.cell)
        if direction is None:
            continue
        offset = cell - near.mean(axis=0)
        if abs(offset[0] * direction[1] - offset[1] * direction[0]) > _ON_LINE_CELLS:
            continue  # off the run's line (a jamb's end face, a corner): not where the wall runs on
        direction = _refined(near, cell, direction, _MIN_RUN_M * per_metre / grid.cell)
        for sign in (1.0, -1.0):
            _follow(grid, hidden, tall, cell, sign * direction, along, out, per_cell, min_gap / grid.cell)
    return out


def _refined(
    cells: np.ndarray, through: np.ndarray, direction: np.ndarray, min_run_cells: float
) -> np.ndarray:
    """The direction of the line through ``through`` that most of the nearby cells lie on.

    Cells off the run's line (a jamb's end face, the stub of a meeting wall) tilt a fit on all of
    them by several degrees; followed across a doorway, a tilted line misses the wall's far part.
    So the line is the one (scanned every degree) with the most cells within ``_ON_LINE_CELLS`` of
    it, refitted on those; the first fit stands when they do not make a run.
    """
    offset = (cells - through).astype(np.float64)
    angles = np.radians(np.arange(0.0, 180.0, 1.0))
    across = np.abs(offset[:, None, 0] * np.sin(angles) - offset[:, None, 1] * np.cos(angles))
    best = angles[int(np.argmax((across <= _ON_LINE_CELLS).sum(axis=0)))]
    on_line = cells[np.abs(offset[:, 0] * np.sin(best) - offset[:, 1] * np.cos(best)) <= _ON_LINE_CELLS]
    refit = _line_direction(np.vstack([on_line, through[None]]), 0.5 * min_run_cells)
    if refit is None:
        return direction
    return refit if refit @ direction >= 0 else -refit


def _line_direction(cells: np.ndarray, min_run_cells: float) -> np.ndarray | None:
    """The unit direction of a straight run of cells, or None when they are not one."""
    if len(cells) < 4:
        return None
    centred = cells - cells.mean(axis=0)
    values, vectors = np.linalg.eigh(centred.T @ centred / len(cells))
    spread_along, spread_across = np.sqrt(max(values[1], 0.0)), np.sqrt(max(values[0], 0.0))
    # a uniform run of length L has a standard deviation of L / sqrt(12) along it
    if spread_along * np.sqrt(12.0) < min_run_cells or spread_across > _MAX_THICKNESS_RATIO * spread_along:
        return None
    return vectors[:, 1]


def _follow(grid: Grid, hidden, tall, cell, direction, along, out, per_cell: float, gap_cells: float) -> None:
    """Mark the hidden cells on the line from ``cell``: through the wall, then on while hidden.

    The wall ends where lines of sight crossed its line over a robot's width: there the line's
    cells and the cells a wall's thickness to either side are all open (looked into, nothing seen
    standing there); a narrower crossing (a grazing ray at the wall's edge) does not end it. Floor
    seen along one face only (at the foot of the wall) does not end it.
    """
    normal = np.array([-direction[1], direction[0]])
    line = cell + along[:, None] * direction
    cells = np.rint(line).astype(np.int64)
    sides = [np.rint(line + k * _SIDE_CELLS * normal).astype(np.int64) for k in (-1.0, 1.0)]
    inside = grid.inside(cells) & grid.inside(sides[0]) & grid.inside(sides[1])
    count = int(np.argmin(inside)) if not inside.all() else len(cells)
    cells, sides = cells[:count], [side[:count] for side in sides]
    standing = grid.occupied | tall | hidden

    def open_at(at: np.ndarray) -> np.ndarray:
        return ~standing[at[:, 0], at[:, 1]]

    crossed = open_at(cells) & open_at(sides[0]) & open_at(sides[1])
    step = along[1] - along[0]
    wide = [first for first, last in _runs(crossed) if (last - first + 1) * step >= gap_cells]
    stop = wide[0] if wide else len(cells)
    standing_wall = grid.occupied | tall
    on_line = standing_wall[cells[:stop, 0], cells[:stop, 1]]
    near = on_line.copy()  # seen standing on the line or a cell or two beside it
    for offset in range(-_RESUMES_ACROSS_CELLS, _RESUMES_ACROSS_CELLS + 1):
        beside = np.rint(line[:stop] + offset * normal).astype(np.int64)
        ok = grid.inside(beside)
        near[ok] |= standing_wall[beside[ok, 0], beside[ok, 1]]
    # Hidden cells on the line are the wall (its unseen face and inside, or its unseen run on) ...
    marked = hidden[cells[:stop, 0], cells[:stop, 1]] & ~on_line
    resumes = int(np.ceil(_RESUMES_M * per_cell / (along[1] - along[0])))
    # ... except in a gap the wall is seen again beyond: a stretch with no wall seen beside the line
    # (hidden cells and seen floor alike: a doorway looked into only part way) followed by seen wall.
    for first, last in _runs(~near):
        after = near[last + 1 : last + 1 + resumes]
        if first > 0 and len(after) == resumes and after.all():
            marked[first : last + 1] = False
    out[cells[:stop][marked, 0], cells[:stop][marked, 1]] = True


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) indices of the runs of True."""
    padded = np.concatenate([[False], flags, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def wall_cells(grid: Grid, tall: np.ndarray, per_metre: float) -> np.ndarray:
    """(H, W) bool: the tall cells that lie on a straight run of at least ``_MIN_RUN_M`` (walls).

    A run's cells are the ones whose tall neighbours within ``_NEIGHBOURHOOD_M`` make a straight
    line through them (a box's corner, a bookshelf's metre of front, a plant are not walls).
    """
    out = np.zeros(grid.shape, bool)
    cells = np.argwhere(tall)
    if len(cells) < 4:
        return out
    reach = _NEIGHBOURHOOD_M * per_metre / grid.cell
    min_run = _MIN_RUN_M * per_metre / grid.cell
    for start in range(0, len(cells), 512):
        chunk = cells[start : start + 512]
        near_all = np.linalg.norm(chunk[:, None, :] - cells[None], axis=2) <= reach
        for cell, near_mask in zip(chunk, near_all, strict=True):
            near = cells[near_mask]
            direction = _line_direction(near, min_run)
            if direction is None:
                continue
            offset = cell - near.mean(axis=0)
            if abs(offset[0] * direction[1] - offset[1] * direction[0]) <= _ON_LINE_CELLS:
                out[cell[0], cell[1]] = True
    return out
