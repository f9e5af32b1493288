"""Keypoint detection and pairwise matching.

SIFT (RootSIFT-normalized) is the default: it is in OpenCV's main module and matches across the
large viewpoint and scale changes of a few hand-held photos. ORB is the fallback for builds
without SIFT, or when asked for. Matches pass Lowe's ratio test in both directions and must be
mutual nearest neighbours, which removes most repeated-texture confusions before RANSAC.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

RATIO = 0.8  # Lowe's ratio: best match must be clearly better than the second best


@dataclass(frozen=True)
class ViewFeatures:
    keypoints: np.ndarray  # (N, 2) float64 pixel positions in the working image
    descriptors: np.ndarray  # (N, D) float32 (SIFT) or uint8 (ORB)
    kind: str  # "sift" or "orb"

    def __len__(self) -> int:
        return len(self.keypoints)


def sift_available() -> bool:
    return hasattr(cv2, "SIFT_create")


def detect_features(gray: np.ndarray, max_features: int, kind: str = "sift") -> ViewFeatures:
    """Keypoints and descriptors of a uint8 grayscale image."""
    if kind == "sift" and sift_available():
        # A lower contrast threshold than OpenCV's 0.04 keeps features on the soft textures of
        # indoor walls and furniture; the ratio test and RANSAC reject what is unreliable.
        detector = cv2.SIFT_create(nfeatures=max_features, contrastThreshold=0.02)
        keypoints, descriptors = detector.detectAndCompute(gray, None)
        kind = "sift"
        if descriptors is not None:
            descriptors = _root_sift(descriptors)
    else:
        detector = cv2.ORB_create(nfeatures=max_features, fastThreshold=10)
        keypoints, descriptors = detector.detectAndCompute(gray, None)
        kind = "orb"
    if descriptors is None or len(keypoints) == 0:
        empty = np.zeros((0, 128 if kind == "sift" else 32), np.float32 if kind == "sift" else np.uint8)
        return ViewFeatures(np.zeros((0, 2)), empty, kind)
    positions = np.array([keypoint.pt for keypoint in keypoints], dtype=np.float64)
    return ViewFeatures(positions, descriptors, kind)


def _root_sift(descriptors: np.ndarray) -> np.ndarray:
    """Hellinger-kernel SIFT: L1-normalize then square-root; compares better under L2."""
    normalized = descriptors / (np.abs(descriptors).sum(axis=1, keepdims=True) + 1e-7)
    return np.sqrt(normalized).astype(np.float32)


def match_features(first: ViewFeatures, second: ViewFeatures) -> np.ndarray:
    """(M, 2) index pairs (into first, into second) of mutual, ratio-tested nearest neighbours."""
    if len(first) < 2 or len(second) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    norm = cv2.NORM_L2 if first.kind == "sift" else cv2.NORM_HAMMING
    matcher = cv2.BFMatcher(norm)
    forward = _ratio_matches(matcher, first.descriptors, second.descriptors)
    backward = _ratio_matches(matcher, second.descriptors, first.descriptors)
    back_lookup = dict(backward)
    mutual = [(i, j) for i, j in forward if back_lookup.get(j) == i]
    if not mutual:
        return np.zeros((0, 2), dtype=np.int64)
    return np.array(mutual, dtype=np.int64)


def _ratio_matches(matcher: cv2.BFMatcher, query: np.ndarray, train: np.ndarray) -> list[tuple[int, int]]:
    pairs = []
    for candidates in matcher.knnMatch(query, train, k=2):
        if len(candidates) == 2 and candidates[0].distance < RATIO * candidates[1].distance:
            pairs.append((candidates[0].queryIdx, candidates[0].trainIdx))
    return pairs
