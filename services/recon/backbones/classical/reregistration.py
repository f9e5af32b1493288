"""A second try for views verification refused, against the adjusted model of the others.

The incremental mapper places a view once, on the model as it stood then: on weak texture the
early model can be a few degrees off, and the view placed on it inherits the error, which
verification then rightly refuses. Once the other views are adjusted without it, the same matches
can place it well. So each refused view is placed again by PnP on the adjusted model's points
(its matches to placed views that reach a triangulated point), its fitting observations are added
to those points' tracks, and it then goes through every check again like the others: a view is
kept only when its checks pass. It is tried once: a view refused again stays refused.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .geometry import project
from .incremental import MIN_PNP_CORRESPONDENCES, SparseModel, solve_pnp
from .triangulation import MAX_REPROJECTION_PX
from .two_view import TwoViewGeometry


def with_views_placed_again(
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    pairs: dict[tuple[int, int], TwoViewGeometry],
    model: SparseModel,
    views: list[int],
) -> tuple[SparseModel, list[int]]:
    """The model with each of `views` placed on it when PnP finds a pose, and the views placed."""
    extrinsics = dict(model.extrinsics)
    tracks = [dict(track) for track in model.tracks]
    placed = []
    for view in views:
        point_ids, pixels = _correspondences(view, keypoints, pairs, model)
        if len(point_ids) < MIN_PNP_CORRESPONDENCES:
            continue
        extrinsic = solve_pnp(model.points[point_ids], pixels, intrinsics[view])
        if extrinsic is None:
            continue
        predicted, depth = project(model.points[point_ids], extrinsic, intrinsics[view])
        fits = (depth > 0) & (np.linalg.norm(predicted - pixels, axis=1) < MAX_REPROJECTION_PX)
        keypoint_of = _keypoints_by_point(view, pairs, model)
        for point in np.asarray(point_ids)[fits]:
            tracks[int(point)][view] = keypoint_of[int(point)]
        extrinsics[view] = extrinsic
        placed.append(view)
    if not placed:
        return model, []
    return replace(model, extrinsics=extrinsics, tracks=tracks), placed


def _keypoints_by_point(
    view: int, pairs: dict[tuple[int, int], TwoViewGeometry], model: SparseModel
) -> dict[int, int]:
    """Point id -> the view's keypoint matched to it (the first found, one keypoint per point)."""
    observed = {(v, k): point for point, track in enumerate(model.tracks) for v, k in track.items()}
    found: dict[int, int] = {}
    used: set[int] = set()
    for (first, second), pair in pairs.items():
        if view not in (first, second):
            continue
        other = second if first == view else first
        if other not in model.extrinsics:
            continue
        own_column, other_column = (0, 1) if first == view else (1, 0)
        for own, theirs in pair.matches[:, [own_column, other_column]].tolist():
            point = observed.get((other, theirs))
            if point is not None and point not in found and own not in used:
                found[point] = own
                used.add(own)
    return found


def _correspondences(
    view: int, keypoints: list[np.ndarray], pairs: dict[tuple[int, int], TwoViewGeometry], model: SparseModel
) -> tuple[list[int], np.ndarray]:
    """The model's points the view's matches reach, and the view's pixels of them."""
    keypoint_of = _keypoints_by_point(view, pairs, model)
    point_ids = sorted(keypoint_of)
    pixels = keypoints[view][[keypoint_of[p] for p in point_ids]] if point_ids else np.zeros((0, 2))
    return point_ids, pixels
