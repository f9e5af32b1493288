"""Ground-truth spatial facts on the floor plane, as a person standing at a camera would state them.

Directions are measured in the camera's *heading frame*: its optical axis and its x axis projected
onto the horizontal plane (perpendicular to the scene's up). Bearings are degrees in (-180, 180]:
0 = straight ahead, +90 = to the right, -90 = to the left, 180 = behind. For a level camera this
equals atan2(x, z) of the point in OpenCV camera coordinates; tilting the camera up or down does
not change it.
"""

from __future__ import annotations

import numpy as np

from shared.geometry.camera_motion import DIRECTIONS

MOTION_DIRECTIONS: tuple[str, ...] = DIRECTIONS  # the wording shared.geometry.camera_motion uses
SECTOR_DEG = 45.0


def camera_centre(extrinsic: np.ndarray) -> np.ndarray:
    extrinsic = np.asarray(extrinsic, np.float64)
    return -extrinsic[:3, :3].T @ extrinsic[:3, 3]


def heading_frame(extrinsic: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit (forward, right) vectors of the camera on the horizontal plane, in world coordinates."""
    up = np.asarray(up, np.float64) / np.linalg.norm(up)
    rotation = np.asarray(extrinsic, np.float64)[:3, :3]
    forward = rotation[2] - (rotation[2] @ up) * up
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    return forward, right / np.linalg.norm(right)


def bearing_deg(extrinsic: np.ndarray, point: np.ndarray, up: np.ndarray) -> float:
    """Horizontal angle of a world point seen from the camera (+ right, - left, ±180 behind)."""
    forward, right = heading_frame(extrinsic, up)
    offset = np.asarray(point, np.float64) - camera_centre(extrinsic)
    return float(np.degrees(np.arctan2(offset @ right, offset @ forward)))


def horizontal_distance(a: np.ndarray, b: np.ndarray, up: np.ndarray) -> float:
    up = np.asarray(up, np.float64) / np.linalg.norm(up)
    offset = np.asarray(b, np.float64) - np.asarray(a, np.float64)
    return float(np.linalg.norm(offset - (offset @ up) * up))


def turn_deg(first: np.ndarray, second: np.ndarray, up: np.ndarray) -> float:
    """Signed heading change from the first camera to the second (+ turned right, - turned left)."""
    forward_2, _ = heading_frame(second, up)
    forward_1, right_1 = heading_frame(first, up)
    return float(np.degrees(np.arctan2(forward_2 @ right_1, forward_2 @ forward_1)))


def sector_of(angle_deg: float) -> tuple[int, float]:
    """The 45-degree sector (index into MOTION_DIRECTIONS) of an angle and its distance to the
    nearest sector boundary in degrees (small = ambiguous)."""
    shifted = (angle_deg + SECTOR_DEG / 2) % 360.0
    index = int(shifted // SECTOR_DEG)
    within = shifted - index * SECTOR_DEG
    return index, float(min(within, SECTOR_DEG - within))


def angle_difference_deg(a: float, b: float) -> float:
    """Absolute difference of two angles on the circle, in [0, 180]."""
    return float(abs((a - b + 180.0) % 360.0 - 180.0))
