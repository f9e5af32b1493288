"""Small pose and projection helpers shared by the reconstruction steps (pure numpy)."""

from __future__ import annotations

import math

import numpy as np


def normalized_coordinates(pixels: np.ndarray, intrinsic: np.ndarray) -> np.ndarray:
    """(N, 2) pixels -> (N, 2) points on the z = 1 plane of the camera."""
    focal = np.array([intrinsic[0, 0], intrinsic[1, 1]])
    centre = np.array([intrinsic[0, 2], intrinsic[1, 2]])
    return (pixels - centre) / focal


def bearings(pixels: np.ndarray, intrinsic: np.ndarray) -> np.ndarray:
    """(N, 3) unit rays in camera axes through the given pixels."""
    plane = normalized_coordinates(pixels, intrinsic)
    rays = np.concatenate([plane, np.ones((len(plane), 1))], axis=1)
    return rays / np.linalg.norm(rays, axis=1, keepdims=True)


def closest_rotation(matrix: np.ndarray) -> np.ndarray:
    """The rotation nearest to a 3x3 matrix in the Frobenius sense."""
    u, _, vt = np.linalg.svd(matrix)
    rotation = u @ vt
    if np.linalg.det(rotation) < 0:
        rotation = u @ np.diag([1.0, 1.0, -1.0]) @ vt
    return rotation


def rotation_between_bearings(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Least-squares R with target ~ R @ source for (N, 3) unit vectors (Kabsch, no translation)."""
    return closest_rotation(target.T @ source)


def compose(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    return np.concatenate([rotation, np.reshape(translation, (3, 1))], axis=1)


def camera_center(extrinsic: np.ndarray) -> np.ndarray:
    return -extrinsic[:, :3].T @ extrinsic[:, 3]


def rotation_angle_deg(rotation: np.ndarray) -> float:
    cosine = np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0)
    return float(np.degrees(np.arccos(cosine)))


def project(
    points: np.ndarray, extrinsic: np.ndarray, intrinsic: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (N, 2) and z-depths (N,) of world points in one camera."""
    camera = points @ extrinsic[:, :3].T + extrinsic[:, 3]
    depth = camera[:, 2]
    safe = np.where(np.abs(depth) < 1e-12, 1e-12, depth)
    pixels = (camera[:, :2] / safe[:, None]) * np.array([intrinsic[0, 0], intrinsic[1, 1]])
    return pixels + np.array([intrinsic[0, 2], intrinsic[1, 2]]), depth


def sampson_distances(
    n1: np.ndarray, n2: np.ndarray, rotation: np.ndarray, translation: np.ndarray
) -> np.ndarray:
    """Signed Sampson distances of the matches to the essential matrix [t]x R (normalized units)."""
    essential = skew(translation) @ rotation
    x1 = np.concatenate([n1, np.ones((len(n1), 1))], axis=1)
    x2 = np.concatenate([n2, np.ones((len(n2), 1))], axis=1)
    forward, backward = x1 @ essential.T, x2 @ essential
    numerator = np.sum(x2 * forward, axis=1)
    denominator = forward[:, 0] ** 2 + forward[:, 1] ** 2 + backward[:, 0] ** 2 + backward[:, 1] ** 2
    return numerator / np.sqrt(np.maximum(denominator, 1e-24))


def skew(vector: np.ndarray) -> np.ndarray:
    x, y, z = vector
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotation_from_vector(rotation_vector: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(rotation_vector))
    if angle < 1e-15:
        return np.eye(3) + skew(rotation_vector)
    axis = skew(rotation_vector / angle)
    return np.eye(3) + math.sin(angle) * axis + (1 - math.cos(angle)) * axis @ axis
