"""Which views the data really supports, and how well: per-view and per-pair confidence.

A wrong pose is worse than no pose. After bundle adjustment every registered view must show:
- enough inliers (observations reprojecting within INLIER_PX),
- spread over the image (a pose from one small patch is poorly constrained),
- a low median reprojection error,
- its points in front of it,
- agreement with the two-view geometry of its best-matched partner (consistency with the others),
- ties to the others: groups of views joined by only a few shared points keep the larger group.
A view that fails is unregistered with the reason; a view whose points all meet at shallow angles
keeps its pose but gets a warning that its position is uncertain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.geometry.reconstruction import PairConfidence, ViewConfidence

from .geometry import camera_center, normalized_coordinates, project, rotation_angle_deg
from .pose_basins import fits_as_well
from .two_view import TwoViewGeometry

INLIER_PX = 3.0  # working-image pixels
# On templeRing, 46-degree pairs held by 38-46 inliers came out 2-6 degrees off even with the true
# focal (28 off with the prior); 80 and more were right.
MIN_VIEW_INLIERS = 50
MIN_VIEW_INLIERS_PRIOR_FOCAL = 50  # a prior focal is a second source of error: never fewer
MIN_PAIR_POINTS = 30  # shared points that tie two views together
MIN_SPREAD = 2 / 16  # at least two cells of a 4x4 grid
MAX_MEDIAN_ERROR_PX = 1.5
MIN_POSITIVE_DEPTH = 0.9
MAX_PAIR_DISAGREEMENT_DEG = 5.0  # model vs two-view relative rotation of a view's best pair
MIN_CONFIDENT_ANGLE_DEG = 2.0  # median ray angle below this: the view's position is uncertain
GRID = 4


@dataclass(frozen=True)
class Observations:
    """Every (point, view) observation with its residual in working pixels and depth."""

    points: np.ndarray  # (O,) point index
    views: np.ndarray  # (O,) view index
    pixels: np.ndarray  # (O, 2) observed keypoint
    errors: np.ndarray  # (O,) reprojection error, working pixels
    depths: np.ndarray  # (O,) z-depth in that view


def observations(
    keypoints: list[np.ndarray],
    intrinsics: dict[int, np.ndarray],
    extrinsics: dict[int, np.ndarray],
    points: np.ndarray,
    tracks: list[dict[int, int]],
) -> Observations:
    point_ids, view_ids, pixels = [], [], []
    for point, track in enumerate(tracks):
        for view, keypoint in track.items():
            if view in extrinsics:
                point_ids.append(point)
                view_ids.append(view)
                pixels.append(keypoints[view][keypoint])
    point_array = np.array(point_ids, dtype=np.int64)
    view_array = np.array(view_ids, dtype=np.int64)
    pixel_array = np.array(pixels, dtype=np.float64).reshape(-1, 2)
    errors = np.full(len(point_array), np.inf)
    depths = np.zeros(len(point_array))
    for view in extrinsics:
        mine = view_array == view
        if mine.any():
            predicted, depth = project(points[point_array[mine]], extrinsics[view], intrinsics[view])
            errors[mine] = np.linalg.norm(predicted - pixel_array[mine], axis=1)
            depths[mine] = depth
    return Observations(point_array, view_array, pixel_array, errors, depths)


def view_confidence(
    view: int, seen: Observations, image_size: tuple[int, int], scale: float
) -> ViewConfidence:
    """Confidence of one registered view; errors reported in original-image pixels."""
    mine = seen.views == view
    good = mine & (seen.errors < INLIER_PX) & (seen.depths > 0)
    width, height = image_size
    cells = set()
    for u, v in seen.pixels[good]:
        cells.add((min(int(u / width * GRID), GRID - 1), min(int(v / height * GRID), GRID - 1)))
    return ViewConfidence(
        inliers=int(good.sum()),
        spread=len(cells) / GRID**2,
        reprojection_error_px=float(np.median(seen.errors[good]) / scale) if good.any() else float("nan"),
        positive_depth_fraction=float(np.mean(seen.depths[mine] > 0)) if mine.any() else float("nan"),
    )


def rejection_reason(confidence: ViewConfidence, scale: float, prior_focal: bool = False) -> str | None:
    needed = MIN_VIEW_INLIERS_PRIOR_FOCAL if prior_focal else MIN_VIEW_INLIERS
    if confidence.inliers < needed:
        reason = f"too few inliers ({confidence.inliers}, at least {needed} needed"
        return reason + (" when the focal length is unknown)" if prior_focal else ")")
    if confidence.spread < MIN_SPREAD:
        return f"its inliers cover too little of the image ({confidence.spread:.0%})"
    if confidence.reprojection_error_px * scale > MAX_MEDIAN_ERROR_PX:
        return f"reprojection error too high ({confidence.reprojection_error_px:.1f} px median)"
    if confidence.positive_depth_fraction < MIN_POSITIVE_DEPTH:
        return f"only {confidence.positive_depth_fraction:.0%} of its points lie in front of it"
    return None


def disagreement_with_pairs(
    view: int,
    extrinsics: dict[int, np.ndarray],
    pairs: dict[tuple[int, int], TwoViewGeometry],
    keypoints: list[np.ndarray] | None = None,
    intrinsics: dict[int, np.ndarray] | None = None,
) -> str | None:
    """The model's rotation to the view's best-matched placed partner vs that pair's own estimate.

    With the keypoints and intrinsics, a disagreement stands only when the pair's matches prefer
    their own pose: when they fit the model's relative pose nearly as well (pose_basins), the pair
    sits in the other of two basins its matches cannot tell apart, and says nothing against the
    model (the pair's uncertainty then states the gap)."""
    best: tuple[int, int] | None = None
    for key, pair in pairs.items():
        if view in key and (key[0] if key[1] == view else key[1]) in extrinsics:
            if best is None or len(pair.matches) > len(pairs[best].matches):
                best = key
    if best is None:
        return None
    first, second = best
    relative = extrinsics[second][:, :3] @ extrinsics[first][:, :3].T
    angle = rotation_angle_deg(relative @ pairs[best].rotation.T)
    if angle > MAX_PAIR_DISAGREEMENT_DEG and not _model_fits_pair(
        pairs[best], first, second, extrinsics, keypoints, intrinsics
    ):
        other = first if second == view else second
        return (
            f"its pose disagrees with its matches to view {other + 1} by {angle:.0f} degrees "
            "(inconsistent with the other views)"
        )
    return None


def _model_fits_pair(
    pair: TwoViewGeometry,
    first: int,
    second: int,
    extrinsics: dict[int, np.ndarray],
    keypoints: list[np.ndarray] | None,
    intrinsics: dict[int, np.ndarray] | None,
) -> bool:
    """Whether the pair's matches support the model's relative pose nearly as well as their own."""
    if keypoints is None or intrinsics is None or pair.model != "essential" or pair.candidates is None:
        return False
    rotation = extrinsics[second][:, :3] @ extrinsics[first][:, :3].T
    translation = extrinsics[second][:, 3] - rotation @ extrinsics[first][:, 3]
    if np.linalg.norm(translation) < 1e-12:
        return False
    matches = pair.candidates
    n1 = normalized_coordinates(keypoints[first][matches[:, 0]], intrinsics[first])
    n2 = normalized_coordinates(keypoints[second][matches[:, 1]], intrinsics[second])
    focal = float(np.mean([intrinsics[first][0, 0], intrinsics[second][0, 0]]))
    return fits_as_well(
        n1, n2, focal, rotation, translation / np.linalg.norm(translation), pair.rotation, pair.translation
    )


def pair_confidences(
    seen: Observations, extrinsics: dict[int, np.ndarray], points: np.ndarray, scales: list[float]
) -> list[PairConfidence]:
    good = (seen.errors < INLIER_PX) & (seen.depths > 0)
    by_view = {view: {} for view in extrinsics}
    for point, view, error in zip(seen.points[good], seen.views[good], seen.errors[good], strict=True):
        by_view[int(view)][int(point)] = float(error) / scales[int(view)]
    result = []
    views = sorted(extrinsics)
    for position, first in enumerate(views):
        for second in views[position + 1 :]:
            shared = sorted(set(by_view[first]) & set(by_view[second]))
            if not shared:
                result.append(PairConfidence(first, second, 0, float("nan"), float("nan")))
                continue
            errors = [by_view[first][p] for p in shared] + [by_view[second][p] for p in shared]
            rays_a = points[shared] - camera_center(extrinsics[first])
            rays_b = points[shared] - camera_center(extrinsics[second])
            cosine = np.sum(rays_a * rays_b, axis=1) / (
                np.linalg.norm(rays_a, axis=1) * np.linalg.norm(rays_b, axis=1) + 1e-12
            )
            angle = float(np.degrees(np.median(np.arccos(np.clip(cosine, -1.0, 1.0)))))
            result.append(PairConfidence(first, second, len(shared), float(np.median(errors)), angle))
    return result


def weakly_tied_views(pairs: list[PairConfidence]) -> dict[int, str]:
    """Views outside the largest group tied together by pairs with MIN_PAIR_POINTS shared points.

    Two groups joined only by a handful of points can each be right and still be wrongly placed
    relative to each other (templeRing, 4 views 46 degrees apart: two good halves, 18 points
    between them, 5 degrees off). The larger group keeps its poses (ties: the lowest view)."""
    views = sorted({p.first for p in pairs} | {p.second for p in pairs})
    group = {view: view for view in views}

    def root(view: int) -> int:
        while group[view] != view:
            view = group[view]
        return view

    for pair in pairs:
        if pair.inliers >= MIN_PAIR_POINTS:
            group[root(pair.second)] = root(pair.first)
    members: dict[int, list[int]] = {}
    for view in views:
        members.setdefault(root(view), []).append(view)
    if len(members) <= 1:
        return {}
    kept = max(members.values(), key=lambda group_views: (len(group_views), -min(group_views)))
    result = {}
    for view in views:
        if view in kept:
            continue
        best = max(
            (p for p in pairs if view in (p.first, p.second) and (p.first in kept or p.second in kept)),
            key=lambda p: p.inliers,
            default=None,
        )
        shared = 0 if best is None else best.inliers
        result[view] = (
            f"only weakly tied to views {', '.join(str(v + 1) for v in kept)} ({shared} shared points, "
            f"at least {MIN_PAIR_POINTS} needed)"
        )
    return result
