"""A passage's width is told only where some line of sight passed between its two sides.

Hand-built metric grids (one scene unit a metre): a wall seen on both sides of a gap; whether the
gap's floor was looked into decides whether the gap is a measured slot or unknown space.
"""

from __future__ import annotations

import numpy as np
import pytest

from shared.navigation.grid import Grid
from shared.navigation.passage import Passage, looked_through

CELL = 0.05


def _wall_with_a_gap(gap_cells: int, looked_into_gap: bool) -> tuple[Grid, Passage]:
    shape = (40, 60)
    grid = Grid(origin=np.zeros(2), cell=CELL, occupied=np.zeros(shape, bool), free=np.ones(shape, bool))
    grid.looked = np.ones(shape, bool)
    row, first, last = 20, 10, 10 + 20 + gap_cells
    grid.occupied[row, first:last] = True
    grid.free[row, first:last] = False
    gap = slice(first + 10, first + 10 + gap_cells)
    grid.occupied[row, gap] = False
    grid.free[row - 3 : row + 4, gap] = False  # nothing seen on the gap's floor ...
    grid.looked[row - 3 : row + 4, gap] = looked_into_gap  # ... and, maybe, no line of sight into it
    sides = grid.to_plane(np.array([[row, gap.start - 1], [row, gap.stop]]))
    where = sides.mean(axis=0)
    return grid, Passage(where, float(np.linalg.norm(sides[1] - sides[0])), (sides[0], sides[1]))


@pytest.mark.parametrize("gap_cells", [4, 9])
def test_a_gap_no_view_looked_into_is_not_a_measured_passage(gap_cells):
    grid, passage = _wall_with_a_gap(gap_cells, looked_into_gap=False)
    assert grid.hidden[20, 20 : 20 + gap_cells].all()  # the premise: the gap is unlooked space
    assert not looked_through(grid, passage)


@pytest.mark.parametrize("gap_cells", [4, 9])
def test_a_gap_some_view_looked_through_is_measured(gap_cells):
    grid, passage = _wall_with_a_gap(gap_cells, looked_into_gap=True)
    assert looked_through(grid, passage)
    grid.looked[20, 20 : 20 + gap_cells] = False  # one line of sight through it suffices
    grid.looked[20, 20 + gap_cells // 2] = True
    assert looked_through(grid, passage)


def test_a_passage_without_two_seen_sides_is_left_to_the_other_rules():
    grid, passage = _wall_with_a_gap(4, looked_into_gap=False)
    assert looked_through(grid, Passage(passage.where, passage.width, None))
