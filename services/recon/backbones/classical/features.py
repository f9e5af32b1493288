"""Keypoint detection and pairwise matching.

SIFT (RootSIFT-normalized) is the default: it is in OpenCV's main module and matches across the
large viewpoint and scale changes of a few hand-held photos. ORB is the fallback for builds
without SIFT, or when asked for.

Affine simulation (after ASIFT): SIFT tolerates a foreshortening ("tilt") of about 2 between two
views of a surface. Walking around an object changes the floor's foreshortening direction by 90
degrees, a tilt of 4 or more between views, and plain SIFT then finds only a handful of correct
matches. So features are also detected on the image compressed horizontally by each factor in
TILTS (anti-aliased first), which views the floor and other receding surfaces as if from higher
up; their positions are mapped back to the original pixels. A keypoint found again at (nearly)
the same place in a simulated view is the same keypoint with one more descriptor.

Matches pass Lowe's ratio test in both directions and must be mutual nearest neighbours, which
removes most repeated-texture confusions before RANSAC. Descriptors of one keypoint never compete
with each other in the ratio test: the runner-up must belong to another keypoint.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

RATIO = 0.8  # Lowe's ratio: best match must be clearly better than the second best
TILTS = (2.0,)  # horizontal compressions simulated besides the image itself
MERGE_PX = 1.5  # a simulated-view keypoint this close to a kept one is that keypoint
NEIGHBOURS = 4  # candidates examined per descriptor to find a runner-up from another keypoint


@dataclass(frozen=True)
class ViewFeatures:
    keypoints: np.ndarray  # (N, 2) float64 pixel positions in the working image
    descriptors: np.ndarray  # (M, D) float32 (SIFT) or uint8 (ORB), M >= N
    owners: np.ndarray  # (M,) int64: the keypoint each descriptor describes
    kind: str  # "sift" or "orb"

    def __len__(self) -> int:
        return len(self.keypoints)


def sift_available() -> bool:
    return hasattr(cv2, "SIFT_create")


def detect_features(gray: np.ndarray, max_features: int, kind: str = "sift") -> ViewFeatures:
    """Keypoints and descriptors of a uint8 grayscale image and of its simulated tilts."""
    kind = "sift" if kind == "sift" and sift_available() else "orb"
    positions, descriptors = _detect(gray, max_features, kind)
    owners = np.arange(len(positions), dtype=np.int64)
    for tilt in TILTS:
        compressed, x_scale = _compress_horizontally(gray, tilt)
        tilted_positions, tilted_descriptors = _detect(compressed, max_features // 2, kind)
        if len(tilted_positions) == 0:
            continue
        # Map back with pixel centres aligned (the cv2.resize pixel-area model).
        tilted_positions[:, 0] = (tilted_positions[:, 0] + 0.5) * x_scale - 0.5
        tilted_owners, positions = _merge_keypoints(positions, tilted_positions)
        descriptors = np.concatenate([descriptors, tilted_descriptors])
        owners = np.concatenate([owners, tilted_owners])
    return ViewFeatures(positions, descriptors, owners, kind)


def _detect(gray: np.ndarray, max_features: int, kind: str) -> tuple[np.ndarray, np.ndarray]:
    if kind == "sift":
        # A lower contrast threshold than OpenCV's 0.04 keeps features on the soft textures of
        # indoor walls and furniture; the ratio test and RANSAC reject what is unreliable.
        detector = cv2.SIFT_create(nfeatures=max_features, contrastThreshold=0.02)
    else:
        detector = cv2.ORB_create(nfeatures=max_features, fastThreshold=10)
    keypoints, descriptors = detector.detectAndCompute(gray, None)
    if descriptors is None or len(keypoints) == 0:
        width = 128 if kind == "sift" else 32
        return np.zeros((0, 2)), np.zeros((0, width), np.float32 if kind == "sift" else np.uint8)
    if kind == "sift":
        descriptors = _root_sift(descriptors)
    return np.array([keypoint.pt for keypoint in keypoints], dtype=np.float64), descriptors


def _compress_horizontally(gray: np.ndarray, tilt: float) -> tuple[np.ndarray, float]:
    """The image shrunk horizontally by `tilt`, and the factor that maps its x back."""
    sigma = 0.8 * np.sqrt(tilt * tilt - 1.0)  # ASIFT's anti-aliasing before subsampling
    blurred = cv2.GaussianBlur(gray, (0, 0), sigmaX=sigma, sigmaY=1e-3)
    width = max(1, int(round(gray.shape[1] / tilt)))
    compressed = cv2.resize(blurred, (width, gray.shape[0]), interpolation=cv2.INTER_LINEAR)
    return compressed, gray.shape[1] / width


def _merge_keypoints(kept: np.ndarray, new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Owners of the new positions (a kept keypoint within MERGE_PX, else a new one) and all keypoints."""
    owners = np.full(len(new), -1, dtype=np.int64)
    if len(kept):
        nearest = cv2.BFMatcher(cv2.NORM_L2).match(new.astype(np.float32), kept.astype(np.float32))
        for match in nearest:
            if match.distance < MERGE_PX:
                owners[match.queryIdx] = match.trainIdx
    fresh = owners < 0
    owners[fresh] = len(kept) + np.arange(int(fresh.sum()))
    return owners, np.concatenate([kept, new[fresh]])


def _root_sift(descriptors: np.ndarray) -> np.ndarray:
    """Hellinger-kernel SIFT: L1-normalize then square-root; compares better under L2."""
    normalized = descriptors / (np.abs(descriptors).sum(axis=1, keepdims=True) + 1e-7)
    return np.sqrt(normalized).astype(np.float32)


def match_features(first: ViewFeatures, second: ViewFeatures) -> np.ndarray:
    """(M, 2) keypoint index pairs (into first, into second) of mutual, ratio-tested nearest neighbours."""
    if len(first) < 2 or len(second) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    forward = _best_keypoint_matches(first, second)
    backward = _best_keypoint_matches(second, first)
    # forward[i] = j and backward[j] = i
    mutual = np.flatnonzero(forward >= 0)
    mutual = mutual[backward[forward[mutual]] == mutual]
    return np.stack([mutual, forward[mutual]], axis=1).astype(np.int64)


def _best_keypoint_matches(query: ViewFeatures, train: ViewFeatures) -> np.ndarray:
    """Per query keypoint: the train keypoint of its closest ratio-tested descriptor match, or -1."""
    indices, distances = nearest_descriptors(query, train, NEIGHBOURS)
    best = np.full(len(query), -1, dtype=np.int64)
    if indices.shape[1] < 2:
        return best
    owners = train.owners[indices]
    # The runner-up is the nearest descriptor of another keypoint than the nearest one's.
    other = owners[:, 1:] != owners[:, :1]
    has_runner_up = other.any(axis=1)
    runner_up = distances[np.arange(len(indices)), other.argmax(axis=1) + 1]
    passed = np.flatnonzero(has_runner_up & (distances[:, 0] < RATIO * runner_up))
    # Several descriptors of one query keypoint: its closest match wins (the first on a tie).
    keypoints = query.owners[passed]
    order = np.lexsort((passed, distances[passed, 0], keypoints))
    first_of_keypoint = np.ones(len(order), dtype=bool)
    first_of_keypoint[1:] = keypoints[order][1:] != keypoints[order][:-1]
    chosen = passed[order[first_of_keypoint]]
    best[query.owners[chosen]] = owners[chosen, 0]
    return best


CANDIDATES = 6  # nearest descriptors kept from the fast single-precision pass
BLOCK_ENTRIES = 1 << 22  # distance-matrix entries computed at once (16 MB in float32)


def nearest_descriptors(
    query: ViewFeatures, train: ViewFeatures, count: int
) -> tuple[np.ndarray, np.ndarray]:
    """The `count` nearest train descriptors of every query descriptor: (N, k) indices and distances,
    nearest first (the lower index first on a tie), k = min(count, train descriptors).

    Exhaustive like OpenCV's brute-force matcher, but as one matrix product per block (BLAS) instead
    of one distance at a time, which is several times faster. The product in single precision only
    picks candidates; their distances are recomputed in double precision and sorted, so the order
    is that of the true distances (the same matches as OpenCV's matcher on templeRing)."""
    a, b = query.descriptors, train.descriptors
    count = min(count, len(b))
    if query.kind != "sift":
        return _nearest_hamming(a, b, count)
    a64, b64 = a.astype(np.float64), b.astype(np.float64)
    b_norms = np.einsum("ij,ij->i", b, b)
    rows = max(1, BLOCK_ENTRIES // max(len(b), 1))
    indices = np.empty((len(a), count), dtype=np.int64)
    distances = np.empty((len(a), count), dtype=np.float64)
    for start in range(0, len(a), rows):
        squared = a[start : start + rows] @ b.T
        squared *= -2.0
        squared += b_norms  # + |a|^2, the same along a row, changes no order
        near = _smallest(squared, min(CANDIDATES, len(b)))
        exact = np.sqrt(np.sum((a64[start : start + rows, None, :] - b64[near]) ** 2, axis=2))
        order = np.lexsort((near, exact), axis=1)[:, :count]
        indices[start : start + rows] = np.take_along_axis(near, order, axis=1)
        distances[start : start + rows] = np.take_along_axis(exact, order, axis=1)
    return indices, distances


def _smallest(values: np.ndarray, count: int) -> np.ndarray:
    """Column indices of the `count` smallest entries of every row (consumes `values`).

    A few passes of argmin are 3-4x faster than np.argpartition for a handful out of thousands."""
    rows = np.arange(len(values))
    chosen = np.empty((len(values), count), dtype=np.int64)
    for position in range(count):
        chosen[:, position] = values.argmin(axis=1)
        values[rows, chosen[:, position]] = np.inf
    return chosen


def _nearest_hamming(a: np.ndarray, b: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """ORB's binary descriptors: OpenCV's brute-force Hamming k-nearest (integer distances, exact)."""
    distances, indices = cv2.batchDistance(a, b, cv2.CV_32S, normType=cv2.NORM_HAMMING, K=count)
    return indices.astype(np.int64), distances.astype(np.float64)
