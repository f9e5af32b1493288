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
the same place in a simulated view is the same keypoint with one more descriptor. On a dark
(brightened) photo the backbone adds the tilts later, and only to views that no pair ties well
(`with_tilts`, backbone.WELL_TIED_MATCHES).

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
BRIGHT_PERCENTILE = 99.5  # the image's "white": a few specular pixels do not set the exposure
MIN_GAIN = 2.5  # a photo whose brightest pixels reach 40% of full scale is not dark: left as it is
MAX_GAIN = 8.0
# A brightened photo keeps only its strongest keypoints: brightening amplifies the sensor noise by
# the gain too, and the weakest responses of a dark photo are mostly that noise. On a synthetic dark
# ring (tuning seeds) the 1,000 strongest of about 2,000 placed more views, more accurately, at a
# third of the time (every stage after detection grows with the keypoints).
DARK_MAX_FEATURES = 1000


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


def detect_features(
    gray: np.ndarray, max_features: int, kind: str = "sift", tilts: tuple[float, ...] = TILTS
) -> ViewFeatures:
    """Keypoints and descriptors of a uint8 grayscale image and of its simulated `tilts`."""
    kind = "sift" if kind == "sift" and sift_available() else "orb"
    image, max_features = _detection_input(gray, max_features)
    positions, descriptors = _detect(image, max_features, kind)
    plain = ViewFeatures(positions, descriptors, np.arange(len(positions), dtype=np.int64), kind)
    return _add_tilts(plain, image, max_features, tilts)


def with_tilts(
    features: ViewFeatures, gray: np.ndarray, max_features: int, tilts: tuple[float, ...] = TILTS
) -> ViewFeatures:
    """`features` (detected without tilts from `gray`) with the simulated tilts' keypoints added:
    the same as detecting with the tilts at once. The existing keypoints keep their indices."""
    image, max_features = _detection_input(gray, max_features)
    return _add_tilts(features, image, max_features, tilts)


def is_dark(gray: np.ndarray) -> bool:
    """Whether detection brightens this photo (exposure_normalized)."""
    return exposure_normalized(gray) is not gray


def _detection_input(gray: np.ndarray, max_features: int) -> tuple[np.ndarray, int]:
    """The image detection runs on (brightened when dark) and its keypoint budget."""
    brightened = exposure_normalized(gray)
    if brightened is not gray:
        max_features = min(max_features, DARK_MAX_FEATURES)
    return brightened, max_features


def _add_tilts(
    features: ViewFeatures, image: np.ndarray, max_features: int, tilts: tuple[float, ...]
) -> ViewFeatures:
    positions, descriptors, owners = features.keypoints, features.descriptors, features.owners
    for tilt in tilts:
        compressed, x_scale = _compress_horizontally(image, tilt)
        tilted_positions, tilted_descriptors = _detect(compressed, max_features // 2, features.kind)
        if len(tilted_positions) == 0:
            continue
        # Map back with pixel centres aligned (the cv2.resize pixel-area model).
        tilted_positions[:, 0] = (tilted_positions[:, 0] + 0.5) * x_scale - 0.5
        tilted_owners, positions = _merge_keypoints(positions, tilted_positions)
        descriptors = np.concatenate([descriptors, tilted_descriptors])
        owners = np.concatenate([owners, tilted_owners])
    return ViewFeatures(positions, descriptors, owners, features.kind)


def exposure_normalized(gray: np.ndarray) -> np.ndarray:
    """The image brightened so that its brightest pixels (BRIGHT_PERCENTILE) reach full scale.

    SIFT's contrast threshold is a fraction of full scale, so a dark photo (a dark object on a
    black background: everything below 50 of 255) loses most of its features to it; the same
    scene exposed brighter keeps them (a synthetic dark ring: about 300 keypoints a view, 1,600-
    2,000 once brightened). The gain is capped (MAX_GAIN) so a nearly black frame's sensor noise
    is not made into texture; photos already using most of the range are left as they are."""
    bright = float(np.percentile(gray, BRIGHT_PERCENTILE))
    gain = min(MAX_GAIN, 255.0 / max(bright, 1.0))
    if gain < MIN_GAIN:
        return gray
    return np.clip(gray.astype(np.float32) * gain, 0, 255).astype(np.uint8)


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
    towards_second, towards_first = nearest_descriptors(first, second, NEIGHBOURS)
    forward = _best_keypoint_matches(first, second, *towards_second)
    backward = _best_keypoint_matches(second, first, *towards_first)
    # forward[i] = j and backward[j] = i
    mutual = np.flatnonzero(forward >= 0)
    mutual = mutual[backward[forward[mutual]] == mutual]
    return np.stack([mutual, forward[mutual]], axis=1).astype(np.int64)


def _best_keypoint_matches(
    query: ViewFeatures, train: ViewFeatures, indices: np.ndarray, distances: np.ndarray
) -> np.ndarray:
    """Per query keypoint: the train keypoint of its closest ratio-tested descriptor match, or -1.
    `indices` and `distances`: the query descriptors' nearest train descriptors, nearest first."""
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
BLOCK_ENTRIES = 1 << 22  # distance-matrix entries held at once, both directions (16 MB in float32)
GROUPS = 64  # a column's entries are split into this many groups to bound its smallest ones

Neighbours = tuple[np.ndarray, np.ndarray]  # (N, k) indices and distances, nearest first


def nearest_descriptors(
    first: ViewFeatures, second: ViewFeatures, count: int
) -> tuple[Neighbours, Neighbours]:
    """The `count` nearest second descriptors of every first descriptor, and the other way round:
    (N, k) indices and distances each, nearest first (the lower index first on a tie),
    k = min(count, descriptors searched).

    Exhaustive like OpenCV's brute-force matcher, but as one matrix product per block (BLAS) instead
    of one distance at a time, which is several times faster; the product serves both directions
    (rows: first to second, columns: second to first). The product in single precision only picks
    candidates; their distances are recomputed in double precision and sorted, so the order is that
    of the true distances (the same matches as OpenCV's matcher on templeRing)."""
    a, b = first.descriptors, second.descriptors
    if first.kind != "sift":
        return _nearest_hamming(a, b, min(count, len(b))), _nearest_hamming(b, a, min(count, len(a)))
    if len(a) == 0 or len(b) == 0:
        return _no_neighbours(len(a), min(count, len(b))), _no_neighbours(len(b), min(count, len(a)))
    towards_second, towards_first = _candidates(a, b)
    return _exact_order(a, b, towards_second, count), _exact_order(b, a, towards_first, count)


def _no_neighbours(rows: int, count: int) -> Neighbours:
    return np.zeros((rows, count), dtype=np.int64), np.zeros((rows, count), dtype=np.float64)


def _candidates(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The CANDIDATES nearest b rows of every a row and nearest a rows of every b row, in single
    precision: (len(a), k) and (len(b), k) indices, in no particular order."""
    a_norms, b_norms = np.einsum("ij,ij->i", a, a), np.einsum("ij,ij->i", b, b)
    # -2 a.b computed as (-2 a).b: scaling by 2 is exact, so the same single-precision values as
    # scaling the product, without a pass over the matrix.
    doubled = a * np.float32(-2.0)
    # Two matrices of a block's size (one per direction); equal blocks, not a sliver at the end.
    rows = _even_block_rows(len(a), max(1, BLOCK_ENTRIES // (2 * len(b))))
    product = np.empty((rows, len(b)), dtype=np.float32)
    along_rows = np.empty((rows, len(b)), dtype=np.float32)
    towards_second = np.empty((len(a), min(CANDIDATES, len(b))), dtype=np.int64)
    blocks = []
    for start in range(0, len(a), rows):
        stop = min(start + rows, len(a))
        block = np.matmul(doubled[start:stop], b.T, out=product[: stop - start])
        # Along a row |a|^2 is the same and changes no order, as |b|^2 along a column.
        np.add(block, b_norms, out=along_rows[: stop - start])
        towards_second[start:stop] = _smallest(along_rows[: stop - start], towards_second.shape[1])
        block += a_norms[start:stop, None]
        found, values = _smallest_in_columns(block, min(CANDIDATES, stop - start))
        blocks.append((found + start, values))
    return towards_second, _merge_blocks(blocks, min(CANDIDATES, len(a)))


def _even_block_rows(total: int, most: int) -> int:
    """Rows per block: at most `most`, in as few blocks of (nearly) equal size as that allows."""
    blocks = max(1, -(-total // most))
    return max(1, -(-total // blocks))


def _smallest(values: np.ndarray, count: int) -> np.ndarray:
    """Column indices of the `count` smallest entries of every row (consumes `values`).

    A few passes of argmin are 3-4x faster than np.argpartition for a handful out of thousands."""
    rows = np.arange(len(values))
    chosen = np.empty((len(values), count), dtype=np.int64)
    for position in range(count):
        chosen[:, position] = values.argmin(axis=1)
        values[rows, chosen[:, position]] = np.inf
    return chosen


def _smallest_in_columns(values: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Row indices and values of the `count` smallest entries of every column, the lower row first
    on a tie: (columns, count) each, ordered by value.

    argmin down columns is slow on a row-major matrix (numpy transposes it). Instead: a column's
    entries in GROUPS groups of rows give GROUPS minima; each is the minimum of different entries,
    so at least `count` entries are at most the count-th smallest minimum, and few more."""
    rows, columns = values.shape
    groups = min(rows, GROUPS)
    stacked = rows // groups
    minima = values[: stacked * groups].reshape(stacked, groups, columns).min(axis=0)
    bounds = np.concatenate([minima, values[stacked * groups :]])
    threshold = np.partition(bounds, count - 1, axis=0)[count - 1]
    flat = np.flatnonzero(values <= threshold)
    found_rows, found_columns = np.divmod(flat, columns)
    # Grouped by column (a stable sort keeps the rows ascending; on 16-bit keys it is a radix
    # sort), then padded to a table with infinity.
    key = found_columns.astype(np.uint16) if columns <= 1 << 16 else found_columns
    by_column = np.argsort(key, kind="stable")
    per_column = np.bincount(found_columns, minlength=columns)
    starts = np.zeros(columns, dtype=np.int64)
    np.cumsum(per_column[:-1], out=starts[1:])
    sorted_columns = found_columns[by_column]
    table = np.full((columns, per_column.max()), np.inf, dtype=np.float32)
    table[sorted_columns, np.arange(len(flat)) - starts[sorted_columns]] = values.ravel()[flat[by_column]]
    nearest = np.argsort(table, axis=1, kind="stable")[:, :count]
    return found_rows[by_column][starts[:, None] + nearest], np.take_along_axis(table, nearest, axis=1)


def _merge_blocks(blocks: list[tuple[np.ndarray, np.ndarray]], count: int) -> np.ndarray:
    """The `count` smallest of every column over all blocks' candidates (the lower row first on a tie)."""
    found = np.concatenate([block_found for block_found, _ in blocks], axis=1)
    values = np.concatenate([block_values for _, block_values in blocks], axis=1)
    if len(blocks) == 1:
        return found
    order = np.lexsort((found, values), axis=1)[:, :count]
    return np.take_along_axis(found, order, axis=1)


def _exact_order(query: np.ndarray, train: np.ndarray, near: np.ndarray, count: int) -> Neighbours:
    """The `count` nearest of every query row's candidate train rows `near`, by their distance in
    double precision (the lower index first on a tie)."""
    count = min(count, near.shape[1])
    indices = np.empty((len(query), count), dtype=np.int64)
    distances = np.empty((len(query), count), dtype=np.float64)
    query = query.astype(np.float64)
    # Differences in chunks that stay in cache (about 1.5 MB each).
    rows = _even_block_rows(len(query), 256)
    differences = np.empty((rows, near.shape[1], query.shape[1]), dtype=np.float64)
    for start in range(0, len(query), rows):
        stop = min(start + rows, len(query))
        chunk = np.subtract(
            query[start:stop, None, :], train[near[start:stop]], out=differences[: stop - start]
        )
        exact = np.sqrt(np.square(chunk, out=chunk).sum(axis=2))
        order = np.lexsort((near[start:stop], exact), axis=1)[:, :count]
        indices[start:stop] = np.take_along_axis(near[start:stop], order, axis=1)
        distances[start:stop] = np.take_along_axis(exact, order, axis=1)
    return indices, distances


def _nearest_hamming(a: np.ndarray, b: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """ORB's binary descriptors: OpenCV's brute-force Hamming k-nearest (integer distances, exact)."""
    distances, indices = cv2.batchDistance(a, b, cv2.CV_32S, normType=cv2.NORM_HAMMING, K=count)
    return indices.astype(np.int64), distances.astype(np.float64)
