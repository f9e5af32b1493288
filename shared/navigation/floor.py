"""The floor plane and the up direction of a reconstruction.

Up starts from the cameras (``estimate_up_axis``: people hold cameras without roll); the floor is
the most populated height below every camera, refined by a plane fit of the points on it, whose
normal then becomes up (the cameras only say roughly where up is; the floor says it exactly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.geometry.poses import estimate_up_axis, up_is_reliable

_BINS_PER_CAMERA_HEIGHT = 100  # histogram resolution: 1.5 cm for cameras 1.5 m above the floor
_MAX_TILT_DEG = 15.0  # a fitted normal further than this from the cameras' up is not the floor
# ... when the headings are too alike to fix up from the cameras (``up_is_reliable``): their up is
# then the mean image up, which a common pitch (views looking down at the floor) tilts as far.
_MAX_TILT_UNRELIABLE_DEG = 40.0
_REFITS = 4
_VOTERS = 20_000  # points sampled for the plane vote
_TRIALS = 300
_PLANE_TOLERANCE = 0.01  # of the cameras' height above the points: an inlier's distance to a plane


@dataclass(frozen=True)
class Floor:
    up: np.ndarray  # (3,) unit normal of the floor, pointing to the cameras
    offset: float  # the floor is {p : p @ up == offset}
    first: np.ndarray  # (3,) unit vector on the floor: the grid's first axis
    second: np.ndarray  # (3,) up x first: counter-clockwise from first seen from above (left)

    def height(self, points: np.ndarray) -> np.ndarray:
        """Signed height of world points above the floor."""
        return np.asarray(points, np.float64).reshape(-1, 3) @ self.up - self.offset

    def to_plane(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) coordinates of world points projected on the floor."""
        points = np.asarray(points, np.float64).reshape(-1, 3)
        return np.stack([points @ self.first, points @ self.second], axis=1)

    def to_world(self, plane: np.ndarray, height: float = 0.0) -> np.ndarray:
        """World points at ``height`` above the floor over (N, 2) floor coordinates."""
        plane = np.asarray(plane, np.float64).reshape(-1, 2)
        base = (self.offset + height) * self.up
        return base + plane[:, :1] * self.first + plane[:, 1:] * self.second


def floor_axes(up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    axis = np.eye(3)[int(np.argmin(np.abs(up)))]
    first = axis - (axis @ up) * up
    first /= np.linalg.norm(first)
    return first, np.cross(up, first)


def _floor_height(heights: np.ndarray, top: float) -> tuple[float, float]:
    """The floor's height along up (the most populated low bin) and the bin width."""
    below = heights[heights < top]
    if len(below) < 10:
        raise ValueError("too few reconstructed points below the cameras to find the floor")
    low = float(np.percentile(below, 0.5))
    width = max((top - low) / _BINS_PER_CAMERA_HEIGHT, 1e-9)
    counts, edges = np.histogram(below, bins=np.arange(low - width, top + width, width))
    peak = int(np.argmax(counts))
    # A lower bin nearly as full is the floor (a big table top can outnumber a partly seen floor).
    candidates = np.flatnonzero(counts[: peak + 1] >= 0.5 * counts[peak])
    chosen = int(candidates[0])
    return float(0.5 * (edges[chosen] + edges[chosen + 1])), width


def _refit(points: np.ndarray, centres: np.ndarray, up: np.ndarray, cameras_up: np.ndarray, limit: float):
    """One refinement: the floor height along ``up``, then a plane fit of the points near it."""
    heights = points @ up
    floor, width = _floor_height(heights, float(np.min(centres @ up)))
    near = points[np.abs(heights - floor) < 2 * width]
    if len(near) >= 3:
        middle = near.mean(axis=0)
        _, _, vt = np.linalg.svd(near - middle, full_matrices=False)
        normal = vt[-1] if vt[-1] @ up >= 0 else -vt[-1]
        if np.degrees(np.arccos(np.clip(normal @ cameras_up, -1.0, 1.0))) < limit:
            up = normal / np.linalg.norm(normal)
            floor = float(np.median(near @ up))
    return up, floor


def _plane_votes(points: np.ndarray, centres: np.ndarray, cameras_up: np.ndarray, limit: float) -> np.ndarray:
    """Up from the best supported plane below every camera, near the cameras' up (RANSAC).

    Few views pitched alike leave the cameras' up some degrees off; then no height bin holds the
    floor, which spans a slope of heights. A plane voted on by the points does not depend on that.
    Of the planes with at least half the best support, the lowest is the floor (a big table top
    can outvote a partly seen floor).
    """
    rng = np.random.default_rng(0)
    sample = points[rng.choice(len(points), min(len(points), _VOTERS), replace=False)]
    depth = float(np.min(centres @ cameras_up) - np.percentile(sample @ cameras_up, 1))
    tolerance = _PLANE_TOLERANCE * max(depth, 1e-9)
    candidates = []
    for _ in range(_TRIALS):
        a, b, c = sample[rng.choice(len(sample), 3, replace=False)]
        normal = np.cross(b - a, c - a)
        if np.linalg.norm(normal) < 1e-12:
            continue
        normal = normal / np.linalg.norm(normal)
        normal = normal if normal @ cameras_up >= 0 else -normal
        if np.degrees(np.arccos(np.clip(normal @ cameras_up, -1.0, 1.0))) >= limit:
            continue
        offset = float(normal @ a)
        if np.min(centres @ normal) <= offset:
            continue
        candidates.append(
            (int(np.count_nonzero(np.abs(sample @ normal - offset) < tolerance)), offset, normal)
        )
    if not candidates:
        return cameras_up
    best = max(count for count, _, _ in candidates)
    strong = [
        (np.min(centres @ normal) - offset, normal)
        for count, offset, normal in candidates
        if count >= 0.5 * best
    ]
    return max(strong, key=lambda item: item[0])[1]


def estimate_floor(points: np.ndarray, extrinsics: np.ndarray) -> Floor:
    """The floor plane of a reconstruction from its points and (registered) cameras.

    The fit is repeated from its own normal: when the cameras' up is a few degrees off (few views,
    all pitched alike), the first band of "floor" points is a slanted slice, and the next is flat.
    """
    points = np.asarray(points, np.float64).reshape(-1, 3)
    points = points[np.all(np.isfinite(points), axis=1)]
    cameras_up = estimate_up_axis(extrinsics)
    rotations, translations = extrinsics[:, :3, :3], extrinsics[:, :3, 3]
    centres = -np.einsum("vji,vj->vi", rotations, translations)
    limit = _MAX_TILT_DEG if up_is_reliable(extrinsics) else _MAX_TILT_UNRELIABLE_DEG
    up = _plane_votes(points, centres, cameras_up, limit) if len(points) >= 3 else cameras_up
    for _ in range(_REFITS):
        previous = up
        up, floor = _refit(points, centres, up, cameras_up, limit)
        if np.degrees(np.arccos(np.clip(up @ previous, -1.0, 1.0))) < 0.05:
            break
    first, second = floor_axes(up)
    return Floor(up=up, offset=floor, first=first, second=second)
