"""Relative poses over a grid of focal hypotheses, for views whose focal the data cannot fix.

Two views (or views whose optical axes meet at one point) fit a range of focal lengths almost
equally well, and the relative rotation turns with the focal. Rather than refuse such a scene, each
placed pair is solved again on the same matches at every horizontal field of view of a grid from
telephoto to wide angle (FOV_GRID_DEG), with the same two-view estimator (essential matrix, or
pure rotation). A hypothesis is kept when it explains nearly as many matches as the best one
(SUPPORT_SHARE) and at least MIN_INLIERS: the data narrow the grid where they can. The matches
cannot rule out a narrow field of view when the optical axes meet; a right angle between the
scene's two largest planes can, as a stated assumption (plane_prior.py). What the kept hypotheses
agree on is then determined (shared/geometry/motion_determinacy.py).

Only scenes whose focal is neither given nor self-calibrated come here; the others pay nothing.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from shared.geometry.motion_determinacy import FOCAL_HYPOTHESIS_REASON, FocalHypotheses, PairHypotheses
from shared.geometry.reconstruction import ViewConfidence

from .intrinsics import guess_intrinsics
from .two_view import MIN_INLIERS, estimate_two_view

FOV_GRID_DEG = tuple(float(fov) for fov in range(10, 101, 5))  # telephoto to wide angle
# A hypothesis explaining fewer matches than this share of the best one is not supported. On
# templeRing pairs the inlier count changes by < 10% over 20-80 degrees, then falls off.
SUPPORT_SHARE = 0.8


def horizontal_fov_deg(focal: float, width: int) -> float:
    return math.degrees(2 * math.atan(width / 2 / focal))


def at_fov(intrinsic: np.ndarray | None, size: tuple[int, int], fov: float) -> np.ndarray:
    return guess_intrinsics(size[0], size[1], fov) if intrinsic is None else intrinsic


def pair_hypotheses(
    first_pixels: np.ndarray,
    second_pixels: np.ndarray,
    first_size: tuple[int, int],
    second_size: tuple[int, int],
    matches: np.ndarray,
    pair: tuple[int, int],
    grid: Iterable[float] = FOV_GRID_DEG,
    given: tuple[np.ndarray | None, np.ndarray | None] = (None, None),
) -> PairHypotheses:
    """The supported hypotheses of one pair (working pixels, sizes as (width, height)); a view with
    `given` intrinsics keeps them at every hypothesis."""
    solved = []
    for fov in grid:
        first_k = at_fov(given[0], first_size, fov)
        second_k = at_fov(given[1], second_size, fov)
        geometry = estimate_two_view(first_pixels, second_pixels, first_k, second_k, matches)
        if geometry is not None:
            solved.append((fov, geometry))
    best = max((len(geometry.matches) for _, geometry in solved), default=0)
    floor = max(MIN_INLIERS, SUPPORT_SHARE * best)
    kept = [(fov, geometry) for fov, geometry in solved if len(geometry.matches) >= floor]
    return PairHypotheses(
        first=pair[0],
        second=pair[1],
        fov_deg=[fov for fov, _ in kept],
        rotations=[geometry.rotation.tolist() for _, geometry in kept],
        translations=[np.asarray(geometry.translation, float).tolist() for _, geometry in kept],
        inliers=[len(geometry.matches) for _, geometry in kept],
    )


def solve_over_focal(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    matches: dict[tuple[int, int], np.ndarray],
    placed: Iterable[int],
    given: list[np.ndarray | None],
    grid: Iterable[float] | None = None,
) -> FocalHypotheses | None:
    """Hypotheses of every pair of placed views that shares matches; None when no pair has one.
    `given`: per view its known intrinsics (kept), or None (the focal is the hypothesis).

    The central hypothesis (the one the stored poses use) is central_fov's."""
    grid = tuple(FOV_GRID_DEG if grid is None else grid)  # read now, so a bench can try another grid
    placed = set(placed)
    pairs = []
    for (first, second), pair_matches in sorted(matches.items()):
        if (
            first not in placed
            or second not in placed
            or (given[first] is not None and given[second] is not None)
        ):
            continue
        hypotheses = pair_hypotheses(
            keypoints[first],
            keypoints[second],
            image_sizes[first],
            image_sizes[second],
            pair_matches,
            (first, second),
            grid,
            (given[first], given[second]),
        )
        if hypotheses.fov_deg:
            pairs.append(hypotheses)
    if not pairs:
        return None
    return FocalHypotheses(tested_fov_deg=list(grid), central_fov_deg=central_fov(pairs), pairs=pairs)


def central_fov(pairs: list[PairHypotheses]) -> float:
    """The middle of the fields of view every pair supports, else of those any pair supports."""
    common = set(pairs[0].fov_deg).intersection(*(pair.fov_deg for pair in pairs[1:]))
    candidates = sorted(common or {fov for pair in pairs for fov in pair.fov_deg})
    return candidates[len(candidates) // 2]


def flag_hypothesis_views(
    confidence: dict[int, ViewConfidence], hypotheses: FocalHypotheses, fov_deg: float
) -> dict[int, ViewConfidence]:
    """Every view of a solved pair is flagged: its pose is the central hypothesis's, one of many
    (a reason already given, e.g. shallow angles, is kept first)."""
    views = {view for pair in hypotheses.pairs for view in (pair.first, pair.second)}
    reason = (
        f"{FOCAL_HYPOTHESIS_REASON} ({fov_deg:.0f} degrees horizontal field of view) of those the "
        "matches support: the focal length is unknown and the views cannot fix it"
    )
    flagged = dict(confidence)
    for view in views & set(confidence):
        given = confidence[view].uncertain_reason
        flagged[view] = replace(confidence[view], uncertain_reason=f"{given}; {reason}" if given else reason)
    return flagged
