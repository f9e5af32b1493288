"""The narrowest field of view a right angle between the scene's two largest planes allows.

Two views whose optical axes meet at one point fit every focal equally well (focal_hypotheses.py):
the reconstructions at different focals are projective distortions of one another, so no match
tells them apart. The scene can, under an assumption about it: a wrong focal also bends the angles
between the scene's planes. The two planes that carry the most points of a room are nearly always
a floor and a wall, or two walls, and those meet at a right angle. At a focal too long for the
photos (a field of view too narrow) that angle closes: on synthetic rooms shot at 60 degrees it is
14-50 degrees at 20-30 degrees of field of view, 71-77 at 50 and 87-90 at 60.

So the narrow end of the grid is dropped, up to one step below the first hypothesis at which the
two largest planes meet within RIGHT_ANGLE_TOLERANCE_DEG of a right angle, and only when a narrower
hypothesis clearly contradicts a right angle (CONTRADICTION_DEG off it, both planes well
supported). The wide end is kept: there the angle folds back past 90 degrees and the smaller
plane's fit degrades, so it does not tell a wide lens from the right one. Scenes without two large
planes, or whose planes never meet at a right angle over the grid, are not narrowed. The warning
that goes with a narrowed range states the assumption.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from shared.geometry.motion_determinacy import FocalHypotheses, PairHypotheses

from .focal_hypotheses import at_fov, central_fov
from .geometry import compose
from .triangulation import triangulate_pair

RIGHT_ANGLE_TOLERANCE_DEG = 10.0  # the planes "meet at a right angle" within this
LEVEL_TOLERANCE_DEG = 30.0  # a floor's normal is this close to the first photo's y (or x) axis
CONTRADICTION_DEG = 20.0  # a narrower hypothesis must be this far off a right angle to be dropped
MIN_POINTS = 60  # triangulated points a hypothesis needs before its planes are fitted
MIN_PLANE_SHARE = 0.10  # each of the two planes carries at least this share of the points
MIN_PLANE_POINTS = 20
PLANE_THRESHOLD = 0.01  # plane inlier distance, as a share of the points' median spread
RANSAC_ROUNDS = 300

ASSUMPTION = (
    "the two planes that carry the most matched points (a floor and a wall, say) meet at a right angle"
)


def two_largest_planes(points: np.ndarray, seed: int = 0) -> list[tuple[np.ndarray, int]]:
    """Unit normals and inlier counts of the largest plane and of the largest one left beside it
    (RANSAC on three points, then a least-squares refit); fewer when too few points remain."""
    rng = np.random.default_rng(seed)
    # Relative to the points' own spread (not to their distance from the camera): a distant object,
    # small in its own depth, is not a plane because it is thin next to the distance.
    threshold = PLANE_THRESHOLD * float(np.median(np.linalg.norm(points - np.median(points, axis=0), axis=1)))
    planes, remaining = [], points
    for _ in range(2):
        if len(remaining) < MIN_PLANE_POINTS:
            break
        samples = remaining[rng.integers(0, len(remaining), (RANSAC_ROUNDS, 3))]
        normals = np.cross(samples[:, 1] - samples[:, 0], samples[:, 2] - samples[:, 0])
        lengths = np.linalg.norm(normals, axis=1)
        usable = lengths > 1e-12
        normals, anchors = normals[usable] / lengths[usable, None], samples[usable, 0]
        if len(normals) == 0:
            break
        offsets = np.sum(normals * anchors, axis=1)[:, None]
        distances = np.abs(np.einsum("kd,nd->kn", normals, remaining) - offsets)
        best = int(np.argmax((distances < threshold).sum(axis=1)))
        inliers = distances[best] < threshold
        centred = remaining[inliers] - remaining[inliers].mean(axis=0)
        normal = np.linalg.svd(centred, full_matrices=False)[2][-1]
        planes.append((normal, int(inliers.sum())))
        remaining = remaining[~inliers]
    return planes


@dataclass(frozen=True)
class PlanePair:
    """The two largest planes of one hypothesis's points (first camera's axes)."""

    angle_deg: float  # between them, 0-90
    level: bool  # one of them faces along the first camera's image x or y axis: a floor, if any


def two_planes(points: np.ndarray) -> PlanePair | None:
    """The two largest planes of the points, or None when they do not hold two well supported ones."""
    if len(points) < MIN_POINTS:
        return None
    planes = two_largest_planes(points)
    floor = max(MIN_PLANE_POINTS, MIN_PLANE_SHARE * len(points))
    if len(planes) < 2 or min(count for _, count in planes) < floor:
        return None
    cosine = abs(float(planes[0][0] @ planes[1][0]))
    # Photos are taken upright or sideways: a floor's normal is near the image's y or x axis.
    level = max(abs(normal[axis]) for normal, _ in planes for axis in (0, 1))
    return PlanePair(
        math.degrees(math.acos(min(1.0, cosine))), level >= math.cos(math.radians(LEVEL_TOLERANCE_DEG))
    )


def pair_points(
    pair: PairHypotheses,
    index: int,
    first_pixels: np.ndarray,
    second_pixels: np.ndarray,
    sizes: tuple[tuple[int, int], tuple[int, int]],
    given: tuple[np.ndarray | None, np.ndarray | None],
) -> np.ndarray:
    """The pair's matches triangulated at its `index`-th hypothesis (first camera's axes), the ones
    that pass the usual checks (in front, reprojecting within a few pixels, a useful ray angle)."""
    fov = pair.fov_deg[index]
    first_k, second_k = at_fov(given[0], sizes[0], fov), at_fov(given[1], sizes[1], fov)
    second = compose(np.asarray(pair.rotations[index]), np.asarray(pair.translations[index]))
    points, kept = triangulate_pair(np.eye(3, 4), second, first_k, second_k, first_pixels, second_pixels)
    return points[kept]


def narrowest_fov(planes: list[tuple[float, PlanePair | None]]) -> float | None:
    """From (field of view, its two planes or None) in increasing field of view: the lower bound the
    right-angle assumption sets, or None when it sets none."""
    contradicted = False
    for position, (_, pair) in enumerate(planes):
        if pair is None:
            continue
        if pair.angle_deg >= 90.0 - RIGHT_ANGLE_TOLERANCE_DEG:
            if not contradicted or not pair.level:
                return None  # nothing narrower is clearly ruled out, or the planes are no floor
            return planes[position - 1][0]  # one step of margin
        if pair.angle_deg < 90.0 - CONTRADICTION_DEG:
            contradicted = True
    return None  # no hypothesis meets at a right angle: the assumption does not hold here


def narrow_by_orthogonal_planes(
    hypotheses: FocalHypotheses,
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    matches: dict[tuple[int, int], np.ndarray],
    given: list[np.ndarray | None],
) -> FocalHypotheses:
    """The hypotheses without the fields of view narrower than every judging pair allows, or as they
    are when no pair judges, or when the bound would leave a pair with no hypothesis.

    A pair judges when its planes set a bound (narrowest_fov); the loosest bound of those counts."""
    bounds = []
    for pair in hypotheses.pairs:
        key = (pair.first, pair.second)
        first_pixels = keypoints[pair.first][matches[key][:, 0]]
        second_pixels = keypoints[pair.second][matches[key][:, 1]]
        sizes = (image_sizes[pair.first], image_sizes[pair.second])
        views = (given[pair.first], given[pair.second])
        planes = [
            (fov, two_planes(pair_points(pair, index, first_pixels, second_pixels, sizes, views)))
            for index, fov in enumerate(pair.fov_deg)
        ]
        bound = narrowest_fov(planes)
        if bound is not None:
            bounds.append(bound)
    if not bounds:
        return hypotheses
    bound = min(bounds)
    pairs = [_from_fov(pair, bound) for pair in hypotheses.pairs]
    if any(not pair.fov_deg for pair in pairs):
        return hypotheses
    return replace(hypotheses, pairs=pairs, central_fov_deg=central_fov(pairs), narrowed_by=ASSUMPTION)


def _from_fov(pair: PairHypotheses, bound: float) -> PairHypotheses:
    kept = [index for index, fov in enumerate(pair.fov_deg) if fov >= bound]
    return replace(
        pair,
        fov_deg=[pair.fov_deg[i] for i in kept],
        rotations=[pair.rotations[i] for i in kept],
        translations=[pair.translations[i] for i in kept],
        inliers=[pair.inliers[i] for i in kept],
    )
