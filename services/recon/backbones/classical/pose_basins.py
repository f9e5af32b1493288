"""Other basins of a pair's relative pose: poses, other than the model's, that the pair's matches
support nearly as well.

The linearised covariance (pair_uncertainty) measures the curvature of the cost at the model's
pose; it cannot see a second minimum. On weak texture a pair's matches can support two poses
several degrees apart about equally, and the model may sit in the wrong one (a synthetic dark
ring: 11.5 degrees off while the curvature said +-1.8). So the pose is searched again, from the
pair's own matches (all of them, not only the model's inliers), among:

- the four decompositions of the model's essential matrix: the mirrored translation and the
  twisted pair (the rotation turned 180 degrees about the baseline) fit every match's epipolar
  constraint exactly as well, and only the side of the cameras the points fall on tells them apart;
- the second-best solution: the essential matrix of the matches the model leaves unexplained;
- RANSAC restarts on resampled matches (the spread of the restarts), each decomposed the same way.
  They run OpenCV's USAC, which seeds its own generator: plain RANSAC draws from OpenCV's global
  one and would change every later fit of the reconstruction.

A candidate that keeps BASIN_SHARE of the model's support (matches within the epipolar threshold
that triangulate in front of both views) is polished to the bottom of its basin. It is a rival when
it stays more than MIN_GAP_DEG away and its robust cost is within RIVAL_COST of the model basin's
own optimum: support counts alone are too loose (with 1,000 matches a pose 13 degrees away still
explains 96% of them, while the data clearly prefer the model). The pair's rotation is then
uncertain by the gap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .geometry import rotation_angle_deg, rotation_from_vector, sampson_distances

BASIN_SHARE = 0.8  # a pose supported by this share of the model's support fits "nearly as well"
RESTARTS = 4  # RANSAC fits on resampled matches
RESAMPLE_SHARE = 0.7  # each restart sees this share of the matches
THRESHOLD_PX = 1.0  # epipolar distance for support, the two-view fit's own
MIN_MATCHES = 15
MIN_GAP_DEG = 2.0  # closer poses are one basin, its spread the covariance measures (RANSAC noise)
MIN_NOISE_PX = 0.25  # keypoints are not located better than this
CUTOFF = 3.0  # noise units: a residual beyond this is a miss, whatever its size
RIVAL_COST = 20.0  # robust cost (squared noise units) within which a basin fits "as well": the
# 99.9% point of chi-square with 5 degrees of freedom, the pose's own spread under noise
POLISH_STEPS = 4
POLISH_MATCHES = 200
MAX_POLISHED = 3  # candidates polished per pair, the best supported first
STEP = 1e-6
SEED = 0  # restarts are resampled deterministically: the same pair gives the same answer


@dataclass(frozen=True)
class RivalBasin:
    gap_deg: float  # rotation between the rival's pose and the model's
    support: int  # matches the rival explains (epipolar and in front of both views)
    model_support: int  # the same count for the model's pose
    kind: str  # "twisted-pair solution", "mirrored solution", "second solution"

    def describe(self) -> str:
        return (
            f"a {self.kind} {self.gap_deg:.0f} degrees away fits nearly as well "
            f"({self.support} matches against {self.model_support})"
        )


def rival_basin(
    n1: np.ndarray, n2: np.ndarray, focal: float, rotation: np.ndarray, translation: np.ndarray
) -> RivalBasin | None:
    """The farthest pose the matches (normalized coordinates) support nearly as well as the
    model's (rotation, unit translation), when more than the noise away; else None.

    A candidate with BASIN_SHARE of the model's support is polished on the matches; if it stays
    apart (a basin of its own) and its robust cost is within RIVAL_COST of the pair's own best
    pose in the model's basin, the data cannot tell the two apart."""
    if len(n1) < MIN_MATCHES or not translation.any():
        return None
    threshold = THRESHOLD_PX / focal
    model_support = _support(n1, n2, rotation, translation, threshold)
    if model_support < MIN_MATCHES:
        return None
    noise = _noise(n1, n2, rotation, translation, threshold, MIN_NOISE_PX / focal)
    # Polishing runs on a fixed sample of the matches (the cost, on all of them): as exact, cheaper.
    sample = np.random.default_rng(SEED).permutation(len(n1))[:POLISH_MATCHES]
    a, b = n1[sample], n2[sample]
    model_cost = _cost(n1, n2, *_polished(a, b, rotation, translation, noise), noise)
    best: RivalBasin | None = None
    for candidate_rotation, candidate_translation, kind in _strongest(
        n1, n2, rotation, translation, threshold, model_support
    ):
        polished = _polished(a, b, candidate_rotation, candidate_translation, noise)
        gap = rotation_angle_deg(polished[0] @ rotation.T)
        if gap < MIN_GAP_DEG or (best is not None and gap <= best.gap_deg):
            continue  # it slid back into the model's basin
        if _cost(n1, n2, *polished, noise) - model_cost <= RIVAL_COST:
            best = RivalBasin(gap, _support(n1, n2, *polished, threshold), model_support, kind)
    return best


def fits_as_well(
    n1: np.ndarray,
    n2: np.ndarray,
    focal: float,
    rotation: np.ndarray,
    translation: np.ndarray,
    fitted_rotation: np.ndarray,
    fitted_translation: np.ndarray,
) -> bool:
    """Whether the matches support a pose (rotation, unit translation) nearly as well as the pose
    the pair's own fit found: polished, it stays in a basin of its own (within MIN_GAP_DEG of where
    it started) whose robust cost is within RIVAL_COST of the fitted pose's basin.

    On weak texture a pair's own fit can sit in the wrong one of two basins its matches support
    alike (a dark ring's 23-degree pairs: 6-13 degrees off with 100-700 inliers), while the
    multi-view model sits in the right one; the pair then does not contradict the model."""
    if len(n1) < MIN_MATCHES or not translation.any() or not fitted_translation.any():
        return False
    threshold = THRESHOLD_PX / focal
    noise = _noise(n1, n2, fitted_rotation, fitted_translation, threshold, MIN_NOISE_PX / focal)
    sample = np.random.default_rng(SEED).permutation(len(n1))[:POLISH_MATCHES]
    a, b = n1[sample], n2[sample]
    fitted_cost = _cost(n1, n2, *_polished(a, b, fitted_rotation, fitted_translation, noise), noise)
    polished = _polished(a, b, rotation, translation, noise)
    if rotation_angle_deg(polished[0] @ rotation.T) >= MIN_GAP_DEG:
        return False  # it slid away: no basin of its own
    return _cost(n1, n2, *polished, noise) - fitted_cost <= RIVAL_COST


def _strongest(
    n1: np.ndarray,
    n2: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    threshold: float,
    model_support: int,
) -> list[tuple[np.ndarray, np.ndarray, str]]:
    """The best-supported candidates (at most MAX_POLISHED), more than MIN_GAP_DEG from the model
    and from each other (restarts often land in one basin: it is polished once), each with at
    least BASIN_SHARE of the model's support."""
    scored = []
    for candidate in _candidates(n1, n2, rotation, translation, threshold):
        if rotation_angle_deg(candidate[0] @ rotation.T) < MIN_GAP_DEG:
            continue
        support = _support(n1, n2, candidate[0], candidate[1], threshold)
        if support >= BASIN_SHARE * model_support:
            scored.append((support, candidate))
    kept: list[tuple[np.ndarray, np.ndarray, str]] = []
    for _, candidate in sorted(scored, key=lambda item: -item[0]):
        if all(rotation_angle_deg(candidate[0] @ other[0].T) >= MIN_GAP_DEG for other in kept):
            kept.append(candidate)
        if len(kept) == MAX_POLISHED:
            break
    return kept


def _noise(
    n1: np.ndarray,
    n2: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    threshold: float,
    floor: float,
) -> float:
    """The matches' noise (normalized units): robust spread of the model's inlier residuals."""
    residuals = np.abs(sampson_distances(n1, n2, rotation, translation))
    inliers = residuals[residuals < threshold]
    if len(inliers) < MIN_MATCHES:
        return max(threshold / 2, floor)
    return max(1.4826 * float(np.median(inliers)), floor)


def _cost(
    n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray, translation: np.ndarray, noise: float
) -> float:
    """Truncated squared errors in noise units (MSAC); a match behind either view is a full miss."""
    squared = np.minimum((sampson_distances(n1, n2, rotation, translation) / noise) ** 2, CUTOFF**2)
    in_front = _in_front(n1, n2, rotation, translation)
    return float(np.sum(np.where(in_front, squared, CUTOFF**2)))


def _polished(
    n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray, translation: np.ndarray, noise: float
) -> tuple[np.ndarray, np.ndarray]:
    """The pose moved to the bottom of its basin: damped Gauss-Newton on the Sampson errors of
    the matches it explains (within CUTOFF noise units, in front of both views)."""
    for _ in range(POLISH_STEPS):
        residual = sampson_distances(n1, n2, rotation, translation) / noise
        kept = (np.abs(residual) < CUTOFF) & _in_front(n1, n2, rotation, translation)
        if kept.sum() < MIN_MATCHES:
            break
        a, b = n1[kept], n2[kept]

        def residuals(step: np.ndarray, pose=(rotation, translation), a=a, b=b) -> np.ndarray:
            return sampson_distances(a, b, *_moved(*pose, step)) / noise

        base = residuals(np.zeros(5))
        jacobian = np.stack([(residuals(e * STEP) - residuals(-e * STEP)) / (2 * STEP) for e in np.eye(5)], 1)
        normal = jacobian.T @ jacobian
        step = -np.linalg.solve(normal + 1e-6 * np.trace(normal) * np.eye(5), jacobian.T @ base)
        rotation, translation = _moved(rotation, translation, step)
        if np.linalg.norm(step) < 1e-7:
            break
    return rotation, translation


def _moved(rotation: np.ndarray, translation: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pose turned by step[:3] (rotation vector) and its direction moved by step[3:]."""
    across = np.linalg.svd(translation.reshape(1, 3))[2][1:]  # two unit vectors orthogonal to t
    moved = translation + step[3:] @ across
    return rotation_from_vector(step[:3]) @ rotation, moved / np.linalg.norm(moved)


def _candidates(
    n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray, translation: np.ndarray, threshold: float
):
    """(rotation, unit translation, kind) of every pose worth scoring against the model's."""
    yield from _decompositions(_essential(rotation, translation), rotation, "model")
    # The second-best solution: the essential matrix of the matches the model does not explain.
    unexplained = ~_supported(n1, n2, rotation, translation, threshold)
    if unexplained.sum() >= MIN_MATCHES:
        yield from _fitted(n1[unexplained], n2[unexplained], rotation, threshold)
    rng = np.random.default_rng(SEED)
    keep = min(POLISH_MATCHES, max(MIN_MATCHES, int(RESAMPLE_SHARE * len(n1))))
    for _ in range(RESTARTS):
        chosen = rng.choice(len(n1), size=min(keep, len(n1)), replace=False)
        yield from _fitted(n1[chosen], n2[chosen], rotation, threshold)


def _fitted(n1: np.ndarray, n2: np.ndarray, model_rotation: np.ndarray, threshold: float):
    """The poses of a RANSAC essential matrix fitted to these matches."""
    essential, _ = cv2.findEssentialMat(
        n1, n2, np.eye(3), method=cv2.USAC_FAST, prob=0.999, threshold=threshold, maxIters=300
    )
    if essential is None:
        return
    for index in range(0, len(essential) - len(essential) % 3, 3):
        yield from _decompositions(essential[index : index + 3], model_rotation, "fitted")


def _decompositions(essential: np.ndarray, model_rotation: np.ndarray, origin: str):
    """The four poses of an essential matrix, named against the model's own pose."""
    first, second, direction = cv2.decomposeEssentialMat(essential)
    direction = direction.ravel() / max(float(np.linalg.norm(direction)), 1e-12)
    for candidate in (first, second):
        twisted = rotation_angle_deg(candidate @ model_rotation.T) > 90.0
        for sign in (1.0, -1.0):
            if origin == "model":
                kind = "twisted-pair solution" if twisted else "mirrored solution"
            else:
                kind = "twisted-pair solution" if twisted else "second solution"
            yield candidate, sign * direction, kind


def _essential(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    x, y, z = translation
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]]) @ rotation


def _support(
    n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray, translation: np.ndarray, threshold: float
) -> int:
    return int(_supported(n1, n2, rotation, translation, threshold).sum())


def _supported(
    n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray, translation: np.ndarray, threshold: float
) -> np.ndarray:
    """Matches within the epipolar threshold (Sampson) that triangulate in front of both views."""
    close = np.abs(sampson_distances(n1, n2, rotation, translation)) < threshold
    return close & _in_front(n1, n2, rotation, translation)


def _in_front(n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Whether each match triangulates in front of both views: depths d1, d2 with
    d2 x2 = d1 R x1 + t, least squares per match."""
    x1 = np.concatenate([n1, np.ones((len(n1), 1))], axis=1)
    x2 = np.concatenate([n2, np.ones((len(n2), 1))], axis=1)
    turned = x1 @ rotation.T
    aa, bb, ab = np.sum(turned * turned, 1), np.sum(x2 * x2, 1), np.sum(turned * x2, 1)
    at, bt = turned @ translation, x2 @ translation
    determinant = ab * ab - aa * bb
    safe = np.where(np.abs(determinant) < 1e-15, math.inf, determinant)
    d1 = (bb * at - ab * bt) / safe
    d2 = (ab * at - aa * bt) / safe
    return (d1 > 0) & (d2 > 0)
