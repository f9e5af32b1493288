"""A spread subsample of the model's tracks for the self-calibration adjustments.

The calibration rounds only need the one shared focal (and poses good enough to rebuild from),
and a few hundred well-spread tracks fix it as well as all of them: on templeRing's four-view
subsets the focal from 500 tracks is within a fraction of a percent of the one from 1600, while
each adjustment (pycolmap's Ceres, single-threaded, often at its iteration cap in the early
rounds) costs about a quarter. The final model still gets one adjustment over every track, with
the focal fixed at the calibrated value.

Each round's adjustment runs coarse to fine (`adjusted_coarse_to_fine`): from the 60 degree prior
the free focal has far to go (templeRing: 554 -> ~1500 px) and Ceres creeps along that curved
valley for ~200 iterations. A spread 100 of the sample's tracks make the same trip at a fifth of
the cost per iteration; the sample's other tracks are then re-triangulated on those poses, and the
whole sample is adjusted from there in a few dozen iterations. It ends in the same minimum (the
nine 4-view templeRing subsets: within 4 px of the one-step focal, 1-4 px in 1300-1500) in about
half the time.

The choice is deterministic (same model, same sample): tracks are binned by the view that first
sees them and a coarse grid cell of their pixel there, longest tracks first in each bin, and the
bins are taken from in turn, so the sample covers every view and the whole image.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .bundle_adjustment import MAX_ITERATIONS, AdjustedModel, bundle_adjust
from .incremental import SparseModel
from .triangulation import projection_matrix, stacked_observations, triangulate_many_views

CALIBRATION_TRACKS = 500
COARSE_TRACKS = 100  # the coarse stage of a calibration adjustment
GRID_CELLS = 6  # per image side


def calibration_sample(
    model: SparseModel,
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    count: int = CALIBRATION_TRACKS,
) -> list[int] | None:
    """Indices of at most `count` spread tracks of `model`, or None to use them all."""
    if len(model.tracks) <= count:
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
    while len(chosen) < count:
        for queue in queues:
            if depth < len(queue) and len(chosen) < count:
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


@dataclass(frozen=True)
class CoarseStage:
    """The first stage of a coarse-to-fine adjustment: where the fine stage starts from."""

    model: SparseModel  # all the tracks, the coarse ones adjusted and the others re-triangulated
    intrinsics: list[np.ndarray]  # with the coarse stage's focal where it was refined
    tracks: list[int] | None  # indices of the coarse tracks in `model`; None: no coarse stage ran
    adjusted: AdjustedModel | None  # the coarse tracks' adjustment, in `tracks`' order


def coarse_stage(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    intrinsics: list[np.ndarray],
    free: list[bool],
    model: SparseModel,
    refine_focal: bool,
    max_iterations: int = MAX_ITERATIONS,
) -> CoarseStage:
    """A spread COARSE_TRACKS of `model`'s tracks adjusted, the others re-triangulated on the poses
    (and focal) that gave; no stage (the model as it is) when it has no more tracks than that."""
    coarse = calibration_sample(model, keypoints, image_sizes, COARSE_TRACKS)
    if coarse is None:
        return CoarseStage(model, intrinsics, None, None)
    few = sampled(model, coarse)
    adjusted = bundle_adjust(
        keypoints,
        image_sizes,
        intrinsics,
        free,
        few.extrinsics,
        few.points,
        few.tracks,
        refine_focal,
        max_iterations,
    )
    if not adjusted.usable:
        return CoarseStage(model, intrinsics, None, None)
    if refine_focal:
        focal = {view: adjusted.intrinsics[view][0, 0] for view in adjusted.intrinsics if free[view]}
        intrinsics = with_focal(intrinsics, free, focal, image_sizes)
    model = with_sample_adjusted(model, coarse, adjusted_model(few, adjusted), keypoints, intrinsics)
    return CoarseStage(model, intrinsics, coarse, adjusted)


def fine_stage(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    free: list[bool],
    stage: CoarseStage,
    refine_focal: bool,
    max_iterations: int = MAX_ITERATIONS,
) -> AdjustedModel:
    """Every track adjusted from where the coarse stage left them."""
    model = stage.model
    return bundle_adjust(
        keypoints,
        image_sizes,
        stage.intrinsics,
        free,
        model.extrinsics,
        model.points,
        model.tracks,
        refine_focal,
        max_iterations,
    )


def adjusted_coarse_to_fine(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    intrinsics: list[np.ndarray],
    free: list[bool],
    model: SparseModel,
    refine_focal: bool,
    max_iterations: int = MAX_ITERATIONS,
    staged: bool = True,
) -> AdjustedModel:
    """`model` adjusted (the free focal refined if `refine_focal`): first a spread COARSE_TRACKS of
    its tracks, then all of them from the poses (and focal) that gave, the other points
    re-triangulated on those. The result is for `model`'s tracks, in their order; `converged` is
    the final stage's. Not `staged`: one adjustment of all of them."""
    if staged:
        stage = coarse_stage(keypoints, image_sizes, intrinsics, free, model, refine_focal, max_iterations)
    else:
        stage = CoarseStage(model, intrinsics, None, None)
    return fine_stage(keypoints, image_sizes, free, stage, refine_focal, max_iterations)


def adjusted_model(model: SparseModel, adjusted: AdjustedModel) -> SparseModel:
    """`model` with the adjusted poses and points (its tracks and other fields kept)."""
    return replace(
        model,
        extrinsics=dict(adjusted.extrinsics),
        points=adjusted.points,
        tracks=list(model.tracks),
        warnings=list(model.warnings),
        guessed_distance=dict(model.guessed_distance),
    )


def with_focal(
    intrinsics: list[np.ndarray],
    free: list[bool],
    focal: dict[int, float],
    image_sizes: list[tuple[int, int]],
) -> list[np.ndarray]:
    """Free views take the estimated focal of a placed free view of the same size."""
    by_size = {image_sizes[v]: f for v, f in focal.items()}
    result = []
    for view, intrinsic in enumerate(intrinsics):
        updated = intrinsic.copy()
        if free[view] and image_sizes[view] in by_size:
            updated[0, 0] = updated[1, 1] = by_size[image_sizes[view]]
        result.append(updated)
    return result
