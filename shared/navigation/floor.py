"""The floor plane and the up direction of a reconstruction.

Up starts from the cameras (``estimate_up_axis``: people hold cameras without roll); the floor is
the most populated height below every camera, refined by a plane fit of the points on it, whose
normal then becomes up (the cameras only say roughly where up is; the floor says it exactly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.geometry.poses import estimate_up_axis

_BINS_PER_CAMERA_HEIGHT = 100  # histogram resolution: 1.5 cm for cameras 1.5 m above the floor
_MAX_TILT_DEG = 15.0  # a fitted normal further than this from the cameras' up is not the floor


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


def _floor_axes(up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def estimate_floor(points: np.ndarray, extrinsics: np.ndarray) -> Floor:
    """The floor plane of a reconstruction from its points and (registered) cameras."""
    points = np.asarray(points, np.float64).reshape(-1, 3)
    points = points[np.all(np.isfinite(points), axis=1)]
    up = estimate_up_axis(extrinsics)
    rotations, translations = extrinsics[:, :3, :3], extrinsics[:, :3, 3]
    centres = -np.einsum("vji,vj->vi", rotations, translations)
    heights = points @ up
    floor, width = _floor_height(heights, float(np.min(centres @ up)))
    near = points[np.abs(heights - floor) < 2 * width]
    if len(near) >= 3:
        middle = near.mean(axis=0)
        _, _, vt = np.linalg.svd(near - middle, full_matrices=False)
        normal = vt[-1] if vt[-1] @ up >= 0 else -vt[-1]
        if np.degrees(np.arccos(np.clip(normal @ up, -1.0, 1.0))) < _MAX_TILT_DEG:
            up = normal / np.linalg.norm(normal)
            floor = float(np.median(near @ up))
    first, second = _floor_axes(up)
    return Floor(up=up, offset=floor, first=first, second=second)
