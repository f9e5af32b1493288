"""Where the views looked: the floor cells some view's line of sight passed over or ended on.

A ray from a camera to what its depth map saw crosses empty space all the way. A floor cell under
such a ray was looked into, even when its floor is hidden (behind a doorway's edge, under a table):
a doorway that a view looked through is open. A cell no ray ever reached (the foot of a wall no
view looked at, the space behind it) is outside the map: a route may not cross it. Without depth
maps (a backbone that gives none) nothing is known either way and every cell counts as looked into.
"""

from __future__ import annotations

import numpy as np

from shared.geometry.reconstruction import Reconstruction
from shared.navigation.floor import Floor
from shared.navigation.grid import Grid

_PIXEL_STRIDE = 4  # every 4th photo pixel each way: rays 4 pixels apart still sweep every cell they pass
_SAMPLES_PER_CELL = 2  # ray samples per cell width along its floor projection


def looked_into(recon: Reconstruction, floor: Floor, grid: Grid) -> np.ndarray | None:
    """(H, W) bool: cells some line of sight passed over or ended on; None without depth maps."""
    if recon.depths is None or all(d is None or d.size == 0 for d in recon.depths):
        return None
    looked = np.zeros(grid.shape, bool)
    for view in np.flatnonzero(recon.registered):
        depth = recon.depths[view]
        if depth is None or depth.size == 0:
            continue
        _mark_view(recon, int(view), depth, floor, grid, looked)
    return looked


def depth_points(
    recon: Reconstruction, view: int, depth: np.ndarray, stride: int
) -> tuple[np.ndarray, np.ndarray]:
    """(world points of every `stride`-th pixel of `depth` that has a depth, the view's camera
    centre). The depth map may be smaller than the photo: its pixel centres are scaled to the
    photo's. Cameras are camera-from-world [R|t], OpenCV axes, intrinsics in the photo's pixels."""
    width, height = recon.image_sizes[view]
    rows, columns = np.mgrid[0 : depth.shape[0] : stride, 0 : depth.shape[1] : stride]
    z = depth[rows, columns].astype(np.float64)
    valid = np.isfinite(z) & (z > 0)
    u = (columns[valid] + 0.5) * width / depth.shape[1] - 0.5
    v = (rows[valid] + 0.5) * height / depth.shape[0] - 0.5
    intrinsic, pose = recon.intrinsics[view], recon.extrinsics[view]
    in_camera = np.stack(
        [
            (u - intrinsic[0, 2]) / intrinsic[0, 0] * z[valid],
            (v - intrinsic[1, 2]) / intrinsic[1, 1] * z[valid],
            z[valid],
        ],
        axis=1,
    )
    return (in_camera - pose[:, 3]) @ pose[:, :3], -pose[:, :3].T @ pose[:, 3]


def _stride(recon: Reconstruction, view: int, depth: np.ndarray) -> int:
    """Depth pixels between rays: ``_PIXEL_STRIDE`` photo pixels. A depth map smaller than the photo
    (a backbone's 80x60 for a 320x240 photo) has rays that far apart at every one of its pixels; at
    every 4th, far floor between them went unmarked, speckled with cells no ray reached."""
    photo_width = float(recon.image_sizes[view][0])
    return max(1, int(round(_PIXEL_STRIDE * depth.shape[1] / photo_width)))


def _mark_view(recon: Reconstruction, view: int, depth: np.ndarray, floor: Floor, grid: Grid, looked) -> None:
    world, camera = depth_points(recon, view, depth, _stride(recon, view, depth))
    if not len(world):
        return
    ends = floor.to_plane(world)
    centre = floor.to_plane(camera)[0]
    longest = float(np.max(np.linalg.norm(ends - centre, axis=1)))
    count = max(int(np.ceil(longest / grid.cell * _SAMPLES_PER_CELL)), 2)
    for t in np.linspace(0.0, 1.0, count):
        cells = grid.to_cell(centre + t * (ends - centre))
        inside = grid.inside(cells)
        looked[cells[inside, 0], cells[inside, 1]] = True
