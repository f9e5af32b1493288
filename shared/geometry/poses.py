"""Rotate, move and turn camera poses (pure numpy).

Poses follow docs/ARCHITECTURE.md: a 3x4 camera-from-world `[R|t]` (4x4 accepted), OpenCV axes
(x right, y down, z forward), camera centre `C = -R.T @ t`. Every tool returns the shape it got.

Up axis: every tool takes an optional world `up` vector. With `up=None` a single camera has no
scene to ask, so its own "image up" direction (camera -y in world) is used: for a level camera this
is the scene up, and for a tilted one the turn stays a pure pan in the image, never a roll. Callers
that know the scene (see `estimate_up_axis`) should pass its up to keep the horizon level.
"""

from __future__ import annotations

import numpy as np

# Orthonormality tolerance of a rotation block: loose enough for float32 network output.
ROTATION_TOLERANCE = 1e-3
# x axes must span a plane this well (about 15 degrees of heading spread) to define up.
_HEADING_SPREAD = 0.25
_DEGENERATE = 1e-6


def validate_extrinsic(extrinsic: np.ndarray) -> np.ndarray:
    """Return `extrinsic` as float64 (3x4 or 4x4) or raise ValueError saying what is wrong."""
    matrix = np.asarray(extrinsic, dtype=np.float64)
    if matrix.shape not in ((3, 4), (4, 4)):
        raise ValueError(f"extrinsic must be 3x4 or 4x4 camera-from-world, got shape {matrix.shape}")
    if not np.all(np.isfinite(matrix)):
        raise ValueError("extrinsic contains non-finite values (nan or inf)")
    if matrix.shape == (4, 4) and not np.allclose(matrix[3], [0.0, 0.0, 0.0, 1.0], atol=ROTATION_TOLERANCE):
        raise ValueError(f"4x4 extrinsic must end with the row [0, 0, 0, 1], got {matrix[3].tolist()}")
    rotation = matrix[:3, :3]
    error = np.abs(rotation @ rotation.T - np.eye(3)).max()
    if error > ROTATION_TOLERANCE:
        raise ValueError(f"rotation block is not orthonormal (max |R R^T - I| = {error:.2e})")
    determinant = np.linalg.det(rotation)
    if determinant < 0:
        raise ValueError(f"rotation block is a reflection (det = {determinant:.3f}, expected +1)")
    return matrix


def as_4x4(extrinsic: np.ndarray) -> np.ndarray:
    """The pose as a 4x4 homogeneous matrix (a copy)."""
    matrix = validate_extrinsic(extrinsic)
    result = np.eye(4)
    result[:3, :] = matrix[:3, :]
    return result


def camera_center(extrinsic: np.ndarray) -> np.ndarray:
    """Camera centre in world coordinates, `-R.T @ t`."""
    matrix = validate_extrinsic(extrinsic)
    return -matrix[:3, :3].T @ matrix[:3, 3]


def _rotations(extrinsics: np.ndarray) -> np.ndarray:
    """(V, 3, 3) rotation blocks of one pose or a stack of poses, each validated."""
    stack = np.asarray(extrinsics, dtype=np.float64)
    if stack.ndim == 2:
        stack = stack[None]
    if stack.ndim != 3 or len(stack) == 0:
        raise ValueError(f"expected one extrinsic or a (V, 3|4, 4) stack, got shape {stack.shape}")
    return np.stack([validate_extrinsic(pose)[:3, :3] for pose in stack])


def estimate_up_axis(extrinsics: np.ndarray) -> np.ndarray:
    """Scene up in world coordinates, estimated from the cameras.

    People hold cameras without roll, so every camera's x axis is horizontal, however much it is
    pitched. When the views face different ways, up is the direction orthogonal to all x axes
    (the least singular vector of their stack): exact for level-roll cameras looking down at a
    subject, where the mean of the -y axes tilts towards the subject. When the headings are too
    alike for that (x axes nearly parallel), the normalized mean of the -y axes is used; it also
    fixes the sign. If those cancel out, the first camera's -y axis is returned.
    """
    rotations = _rotations(extrinsics)
    image_ups = -rotations[:, 1, :]  # camera -y axis in world is -R[1, :]
    mean = image_ups.mean(axis=0)
    norm = np.linalg.norm(mean)
    reference = image_ups[0] / np.linalg.norm(image_ups[0]) if norm < _DEGENERATE else mean / norm
    if len(rotations) >= 2:
        _, singular, vt = np.linalg.svd(rotations[:, 0, :])
        if singular[1] > _HEADING_SPREAD * singular[0]:
            normal = vt[-1] / np.linalg.norm(vt[-1])
            return normal if normal @ reference >= 0 else -normal
    return reference


def up_is_reliable(extrinsics: np.ndarray) -> bool:
    """Whether `estimate_up_axis` fixes up from the cameras rather than assuming their images are upright.

    With headings that spread (x axes spanning a plane), up is the normal to all x axes whatever
    each photo's roll; with alike headings it is the mean image up, which a set of photos all held
    sideways would put sideways too, so it is no gravity frame.
    """
    rotations = _rotations(extrinsics)
    if len(rotations) < 2:
        return False
    singular = np.linalg.svd(rotations[:, 0, :], compute_uv=False)
    return bool(singular[1] > _HEADING_SPREAD * singular[0])


def _unit_up(up: np.ndarray | None, rotation: np.ndarray) -> np.ndarray:
    if up is None:
        return -rotation[1]
    vector = np.asarray(up, dtype=np.float64).reshape(-1)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise ValueError(f"up must be 3 finite numbers, got {np.asarray(up).tolist()}")
    norm = np.linalg.norm(vector)
    if norm < _DEGENERATE:
        raise ValueError("up must not be the zero vector")
    return vector / norm


def axis_angle_matrix(axis: np.ndarray, angle_deg: float) -> np.ndarray:
    """Right-handed rotation by `angle_deg` about the unit `axis` (Rodrigues)."""
    theta = np.radians(angle_deg)
    x, y, z = axis
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(theta) * cross + (1.0 - np.cos(theta)) * (cross @ cross)


def _with_pose(original: np.ndarray, rotation: np.ndarray, center: np.ndarray) -> np.ndarray:
    """Build a pose of the same shape as `original` from a rotation and a camera centre."""
    result = original.copy()
    result[:3, :3] = rotation
    result[:3, 3] = -rotation @ center
    return result


def yaw(extrinsic: np.ndarray, angle: float, up: np.ndarray | None = None) -> np.ndarray:
    """Turn the camera in place by `angle` degrees about `up`; positive turns left.

    A right-handed turn about the up axis swings the optical axis (+z) toward the camera's -x side,
    so what was on the left of the image moves toward its centre.
    """
    matrix = validate_extrinsic(extrinsic)
    rotation = matrix[:3, :3]
    axis = _unit_up(up, rotation)
    center = -rotation.T @ matrix[:3, 3]
    # World vectors turn by Q, so the camera's axes (rows of R) become rows of R @ Q.T.
    turned = rotation @ axis_angle_matrix(axis, angle).T
    return _with_pose(matrix, turned, center)


def rotate_left(extrinsic: np.ndarray, angle: float = 45.0, up: np.ndarray | None = None) -> np.ndarray:
    """Turn toward the image's left side by `angle` degrees; the centre does not move."""
    return yaw(extrinsic, angle, up)


def rotate_right(extrinsic: np.ndarray, angle: float = 45.0, up: np.ndarray | None = None) -> np.ndarray:
    """Turn toward the image's right side by `angle` degrees; the centre does not move."""
    return yaw(extrinsic, -angle, up)


def turn_around(extrinsic: np.ndarray, up: np.ndarray | None = None) -> np.ndarray:
    """Face the opposite way (180 degrees about up); the centre does not move."""
    return yaw(extrinsic, 180.0, up)


def horizontal_forward(rotation: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Unit viewing direction projected onto the plane orthogonal to `up` (world).

    A camera looking straight along up (or down) has no horizontal viewing direction; then the
    direction toward the top of its image (camera -y) is used, which is where "ahead" is in a
    photo taken straight down.
    """
    for candidate in (rotation[2], -rotation[1]):
        flat = candidate - np.dot(candidate, up) * up
        norm = np.linalg.norm(flat)
        if norm > 1e-3:
            return flat / norm
    raise ValueError("camera axes are degenerate against the up axis")


def move_forward(extrinsic: np.ndarray, distance: float = 0.3, up: np.ndarray | None = None) -> np.ndarray:
    """Move the centre `distance` along the horizontal viewing direction; orientation and height stay."""
    matrix = validate_extrinsic(extrinsic)
    if not np.isfinite(distance):
        raise ValueError(f"distance must be finite, got {distance}")
    rotation = matrix[:3, :3]
    axis = _unit_up(up, rotation)
    center = -rotation.T @ matrix[:3, 3]
    return _with_pose(matrix, rotation, center + distance * horizontal_forward(rotation, axis))


def move_backward(extrinsic: np.ndarray, distance: float = 0.3, up: np.ndarray | None = None) -> np.ndarray:
    """Move the centre `distance` against the horizontal viewing direction."""
    return move_forward(extrinsic, -distance, up)


__all__ = [
    "as_4x4",
    "axis_angle_matrix",
    "camera_center",
    "estimate_up_axis",
    "horizontal_forward",
    "move_backward",
    "move_forward",
    "rotate_left",
    "rotate_right",
    "turn_around",
    "validate_extrinsic",
    "yaw",
]
