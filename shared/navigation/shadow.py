"""Behind a seen obstacle: the unlooked cells its unseen body most likely fills.

A depth pixel that meets something at the robot's body height sees only that thing's front face;
the object goes on behind it, into space no line of sight reached. Furniture is at least a few
decimetres deep, so the unlooked cells within ``depth`` behind a seen face, along the line of
sight (on the floor), are taken as the object (``shadows``): a route opened across unlooked space
goes round them rather than through the part of a box that no view saw. The march behind a face
stops at the first cell some view looked into without seeing anything standing there (the object
ended before it). Walls are left out (their continuation is ``walls.continued_walls``): a ray that
grazes a wall's face beside a doorway would carry the shadow into the doorway itself.

Camera conventions: ``recon.extrinsics`` are 3x4 camera-from-world [R|t], OpenCV axes (x right,
y down, z forward), ``recon.intrinsics`` 3x3 in pixels; depth maps hold z in the camera frame.
"""

from __future__ import annotations

import numpy as np

from shared.geometry.reconstruction import Reconstruction
from shared.navigation.floor import Floor
from shared.navigation.grid import Grid
from shared.navigation.sight import depth_points

_PIXEL_STRIDE = 2  # every 2nd pixel each way
_SAMPLES_PER_CELL = 2  # march samples per cell width behind a face


def shadows(
    recon: Reconstruction,
    floor: Floor,
    grid: Grid,
    band: tuple[float, float],
    depth: float,
    walls: np.ndarray,
) -> np.ndarray:
    """(H, W) bool: unlooked cells within ``depth`` (scene units) behind a seen face at body height.

    ``band``: the robot's body (low, high) above the floor, scene units. ``walls``: (H, W) cells of
    walls; a face seen on one casts nothing.
    """
    out = np.zeros(grid.shape, bool)
    if recon.depths is None or grid.looked is None:
        return out
    for view in np.flatnonzero(recon.registered):
        map_ = recon.depths[view]
        if map_ is None or map_.size == 0:
            continue
        hits, centre = _body_hits(recon, int(view), map_, floor, band)
        out |= behind_faces(grid, hits, centre, depth, walls)
    return out


def _body_hits(
    recon: Reconstruction, view: int, depth: np.ndarray, floor: Floor, band: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Floor coordinates of the view's depth points at body height, and of its camera."""
    world, camera = depth_points(recon, view, depth, _PIXEL_STRIDE)
    heights = floor.height(world)
    body = (heights >= band[0]) & (heights <= band[1])
    return floor.to_plane(world[body]), floor.to_plane(camera)[0]


def behind_faces(
    grid: Grid, hits: np.ndarray, centre: np.ndarray, depth: float, walls: np.ndarray
) -> np.ndarray:
    """(H, W) bool: the unlooked cells up to ``depth`` behind each hit, away from the camera.

    ``hits`` (N, 2) and ``centre`` (2,) are floor coordinates of the seen points at body height
    and of the camera that saw them; ``depth`` is in scene units.
    """
    out = np.zeros(grid.shape, bool)
    hit_cells = grid.to_cell(hits)
    inside = grid.inside(hit_cells)
    hits, hit_cells = hits[inside], hit_cells[inside]
    # a face on an occupied cell (a stray point is not one), not on a wall
    keep = grid.occupied[hit_cells[:, 0], hit_cells[:, 1]] & ~walls[hit_cells[:, 0], hit_cells[:, 1]]
    hits = hits[keep]
    if not len(hits):
        return out
    direction = hits - centre
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-12)
    hidden, standing = grid.hidden, grid.occupied
    alive = np.ones(len(hits), bool)
    count = max(int(np.ceil(depth / grid.cell * _SAMPLES_PER_CELL)), 1)
    for t in np.linspace(0.0, depth, count + 1)[1:]:
        cells = grid.to_cell(hits + t * direction)
        ok = alive & grid.inside(cells)
        rows, cols = cells[:, 0].clip(0, grid.shape[0] - 1), cells[:, 1].clip(0, grid.shape[1] - 1)
        # looked into and nothing standing: the object ended before this cell
        alive &= ok & (hidden[rows, cols] | standing[rows, cols])
        marks = alive & hidden[rows, cols]
        out[rows[marks], cols[marks]] = True
    return out
