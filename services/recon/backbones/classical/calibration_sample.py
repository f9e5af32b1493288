"""A spread subsample of the model's tracks for the self-calibration adjustments.

The calibration rounds only need the one shared focal (and poses good enough to rebuild from),
and a few hundred well-spread tracks fix it as well as all of them: on templeRing's four-view
subsets the focal from 500 tracks is within a fraction of a percent of the one from 1600, while
each adjustment (pycolmap's Ceres, single-threaded, often at its iteration cap in the early
rounds) costs about a quarter. The final model still gets one adjustment over every track, with
the focal fixed at the calibrated value.

The choice is deterministic (same model, same sample): tracks are binned by the view that first
sees them and a coarse grid cell of their pixel there, longest tracks first in each bin, and the
bins are taken from in turn, so the sample covers every view and the whole image.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .incremental import SparseModel
from .triangulation import projection_matrix, stacked_observations, triangulate_many_views

CALIBRATION_TRACKS = 500
GRID_CELLS = 6  # per image side


def calibration_sample(
    model: SparseModel, keypoints: list[np.ndarray], image_sizes: list[tuple[int, int]]
) -> list[int] | None:
    """Indices of at most CALIBRATION_TRACKS spread tracks of `model`, or None to use them all."""
    if len(model.tracks) <= CALIBRATION_TRACKS:
        return None
    bins: dict[tuple[int, int, int], list[tuple[int, int]]] = {}
    for index, track in enumerate(model.tracks):
        views = [view for view in track if view in model.extrinsics]
        anchor = min(views) if views else min(track)
        x, y = keypoints[anchor][track[anchor]]
        width, height = image_sizes[anchor]
        cell_x = min(max(int(x / width * GRID_CELLS), 0), GRID_CELLS - 1)
        cell_y = min(max(int(y / height * GRID_CELLS), 0), GRID_CELLS - 1)
        bins.setdefault((anchor, cell_x, cell_y), []).append((-len(views), index))
    queues = [sorted(members) for _, members in sorted(bins.items())]
    chosen: list[int] = []
    depth = 0
    while len(chosen) < CALIBRATION_TRACKS:
        for queue in queues:
            if depth < len(queue) and len(chosen) < CALIBRATION_TRACKS:
                chosen.append(queue[depth][1])
        depth += 1
    return sorted(chosen)


def sampled(model: SparseModel, sample: list[int] | None) -> SparseModel:
    if sample is None:
        return model
    # replace() keeps every other field (warnings, guessed distances) with the model
    return replace(model, points=np.asarray(model.points)[sample], tracks=[model.tracks[i] for i in sample])


def with_sample_adjusted(
    model: SparseModel,
    sample: list[int],
    adjusted: SparseModel,
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
) -> SparseModel:
    """Every track of `model` on the adjusted sample's poses: the sample's points as adjusted, the
    others re-triangulated (linear, from all their views) with those poses and `intrinsics`; a
    point that does not triangulate keeps its old position."""
    views = sorted(adjusted.extrinsics)
    matrices = {view: projection_matrix(adjusted.extrinsics[view], intrinsics[view]) for view in views}
    projections, pixels, seen = stacked_observations(model.tracks, views, keypoints, matrices)
    points = np.array(model.points, dtype=np.float64).reshape(-1, 3).copy()
    solved = triangulate_many_views(projections, pixels, seen)
    usable = np.all(np.isfinite(solved), axis=1) & (seen.sum(axis=1) >= 2)
    points[usable] = solved[usable]
    points[sample] = adjusted.points
    return replace(model, extrinsics=dict(adjusted.extrinsics), points=points, tracks=list(model.tracks))
