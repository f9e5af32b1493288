"""An occupancy grid on the floor: what the robot's body would hit, what was seen free, what not.

Cells are square, ``cell`` scene units wide, indexed (row, column) = (second axis, first axis)
of the floor plane (``Floor.to_plane``). Three kinds: occupied (points at body height), free
(floor seen and nothing at body height) and unknown (no view saw the floor there). Unknown is
not an obstacle: the planner may cross it, at a higher cost, and says where it did.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

_MAX_CELLS = 250_000  # a larger scene gets coarser cells rather than a slow search
_OCCUPIED_MIN_POINTS = 2  # one stray point does not block a cell


@dataclass
class Grid:
    origin: np.ndarray  # (2,) floor coordinates of the centre of cell (0, 0)
    cell: float  # cell width in scene units
    occupied: np.ndarray  # (H, W) bool
    free: np.ndarray  # (H, W) bool: floor seen, nothing at body height
    # (K, 2) floor coordinates of the points at body height: a passage is measured on these, not on
    # cell centres, so its width is what a tape measure between the seen surfaces would give.
    obstacle_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    # (H, W) bool: cells some view's line of sight passed over (``sight.looked_into``); None: unknown.
    looked: np.ndarray | None = None
    # (H, W) bool: cells with surfaces seen above ``build_grid``'s ``tall_height`` (walls, tall furniture)
    tall: np.ndarray | None = None

    @property
    def hidden(self) -> np.ndarray:
        """(H, W) bool: unseen cells that no line of sight reached: outside the map."""
        if self.looked is None:
            return np.zeros(self.shape, bool)
        return self.unseen & ~self.looked

    @property
    def blocked(self) -> np.ndarray:
        """Occupied cells and the map's edge: the grid's outer ring and the cells no view looked into."""
        out = self.occupied | self.hidden
        out[[0, -1], :] = True
        out[:, [0, -1]] = True
        return out

    @property
    def unseen(self) -> np.ndarray:
        """(H, W) bool: no view saw the floor and nothing was seen at body height."""
        return ~self.free & ~self.occupied

    @property
    def shape(self) -> tuple[int, int]:
        return self.occupied.shape

    def to_cell(self, plane: np.ndarray) -> np.ndarray:
        """(N, 2) integer (row, column) of floor coordinates (may fall outside the grid)."""
        plane = np.asarray(plane, np.float64).reshape(-1, 2)
        indices = np.rint((plane - self.origin) / self.cell).astype(np.int64)
        return indices[:, ::-1]

    def to_plane(self, cells: np.ndarray) -> np.ndarray:
        cells = np.asarray(cells, np.float64).reshape(-1, 2)
        return cells[:, ::-1] * self.cell + self.origin

    def inside(self, cells: np.ndarray) -> np.ndarray:
        cells = np.asarray(cells).reshape(-1, 2)
        return (
            (cells[:, 0] >= 0)
            & (cells[:, 1] >= 0)
            & (cells[:, 0] < self.shape[0])
            & (cells[:, 1] < self.shape[1])
        )

    def occupied_centres(self) -> np.ndarray:
        """(K, 2) floor coordinates of the occupied cells' centres."""
        return self.to_plane(np.argwhere(self.occupied))


def disc_offsets(radius_cells: float) -> np.ndarray:
    """(K, 2) integer offsets within a disc of this radius in cells (the centre included)."""
    reach = int(np.ceil(radius_cells))
    rows, columns = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    inside = rows**2 + columns**2 <= radius_cells**2 + 1e-9
    return np.stack([rows[inside], columns[inside]], axis=1)


def dilate(mask: np.ndarray, radius_cells: float) -> np.ndarray:
    """Cells within ``radius_cells`` of a set cell (a disc-shaped dilation by shifts)."""
    if radius_cells <= 0 or not mask.any():
        return mask.copy()
    reach = int(np.ceil(radius_cells))
    padded = np.pad(mask, reach)
    out = np.zeros_like(mask)
    height, width = mask.shape
    for dr, dc in disc_offsets(radius_cells):
        out |= padded[reach + dr : reach + dr + height, reach + dc : reach + dc + width]
    return out


def erode(mask: np.ndarray, radius_cells: float) -> np.ndarray:
    return ~dilate(~mask, radius_cells)


def _counts(cells: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    inside = (cells[:, 0] >= 0) & (cells[:, 1] >= 0) & (cells[:, 0] < shape[0]) & (cells[:, 1] < shape[1])
    flat = cells[inside, 0] * shape[1] + cells[inside, 1]
    return np.bincount(flat, minlength=shape[0] * shape[1]).reshape(shape)


def _walls_above(grid: Grid, plane: np.ndarray, heights: np.ndarray, top: float) -> np.ndarray:
    """Cells where a vertical surface was seen just above the body: a wall whose foot no view saw.

    Its seen part starts within ``top`` above the body and rises at least ``top`` more. A table top
    is flat and a lintel starts far higher, so neither closes the floor below it; a doorway between
    seen walls stays open.
    """
    above = (heights > top) & (heights <= 3 * top)
    cells = grid.to_cell(plane[above])
    inside = grid.inside(cells)
    flat = cells[inside, 0] * grid.shape[1] + cells[inside, 1]
    size = grid.shape[0] * grid.shape[1]
    low = np.full(size, np.inf)
    high = np.full(size, -np.inf)
    np.minimum.at(low, flat, heights[above][inside])
    np.maximum.at(high, flat, heights[above][inside])
    wall = (low <= 2 * top) & (high - low >= top)
    return wall.reshape(grid.shape)


def build_grid(
    plane: np.ndarray,
    heights: np.ndarray,
    band: tuple[float, float],
    cell: float,
    floor_tolerance: float,
    close_cells: float,
    keep: np.ndarray,
    tall_height: float = np.inf,
    height_noise: np.ndarray | None = None,
) -> Grid:
    """The grid of floor-projected points ``plane`` with their ``heights`` above the floor.

    ``band`` is the robot's body (low, high); points within ``floor_tolerance`` of the floor mark
    it seen. Small holes in the seen floor (between the samples of a distant, grazing view) are
    closed by ``close_cells``. ``keep`` (M, 2) are floor points the grid must cover (start, goal).
    Cells with points seen above ``tall_height`` are ``tall`` (what a wall is made of).
    ``height_noise`` (N,), when given, is how far each point's height cannot be told from the floor
    (``noise.height_tolerance``): a point within it is floor, not an obstacle, up to half the body's
    height (what stands higher than that is an obstacle however noisy its points).
    """
    noise = np.zeros(len(heights)) if height_noise is None else np.minimum(height_noise, 0.5 * band[1])
    in_band = (heights >= np.maximum(band[0], noise)) & (heights <= band[1])
    on_floor = np.abs(heights) <= np.maximum(floor_tolerance, noise)
    relevant = np.concatenate([plane[in_band | on_floor], keep])
    low, high = relevant.min(axis=0) - 4 * cell, relevant.max(axis=0) + 4 * cell
    while np.prod(np.ceil((high - low) / cell) + 1) > _MAX_CELLS:
        cell *= 1.25
    shape = tuple(int(n) for n in (np.ceil((high - low) / cell) + 1)[::-1])
    grid = Grid(
        origin=low,
        cell=cell,
        occupied=np.zeros(shape, bool),
        free=np.zeros(shape, bool),
        obstacle_points=plane[in_band],
    )
    occupied = _counts(grid.to_cell(plane[in_band]), shape) >= _OCCUPIED_MIN_POINTS
    occupied |= _walls_above(grid, plane, heights, band[1])
    # Only surfaces are seen: the inside of a thin obstacle (a wall between its two faces) is closed.
    grid.occupied = occupied | erode(dilate(occupied, 1.5), 1.5)
    grid.tall = _counts(grid.to_cell(plane[heights >= tall_height]), shape) >= _OCCUPIED_MIN_POINTS
    seen = _counts(grid.to_cell(plane[on_floor]), shape) > 0
    seen = erode(dilate(seen, close_cells), close_cells)
    grid.free = seen & ~grid.occupied
    return grid
