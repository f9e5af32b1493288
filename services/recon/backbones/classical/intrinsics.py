"""Intrinsics for photos whose camera is unknown, and the map between original and working pixels.

The guess is a pinhole with square pixels, the principal point at the image centre and a focal
length from an assumed horizontal field of view (60 degrees by default: typical of phone and
webcam photos once cropped to 4:3 or 16:9). Pixel (u, v) is the integer index, so the centre of a
W-pixel-wide image is at u = (W - 1) / 2.
"""

from __future__ import annotations

import math

import numpy as np


def guess_intrinsics(width: int, height: int, fov_deg: float) -> np.ndarray:
    """3x3 pinhole intrinsics whose horizontal field of view is `fov_deg`."""
    if not 1.0 < fov_deg < 179.0:
        raise ValueError(f"horizontal field of view must be in (1, 179) degrees, got {fov_deg}")
    focal = (width / 2.0) / math.tan(math.radians(fov_deg) / 2.0)
    return np.array(
        [[focal, 0.0, (width - 1) / 2.0], [0.0, focal, (height - 1) / 2.0], [0.0, 0.0, 1.0]],
        dtype=np.float64,
    )


def resize_transform(scale: float) -> np.ndarray:
    """Pixel map from an image to the same image resized by `scale` (cv2.resize pixel-area model).

    Pixel centres line up, so original u maps to (u + 0.5) * scale - 0.5.
    """
    offset = 0.5 * scale - 0.5
    return np.array([[scale, 0.0, offset], [0.0, scale, offset], [0.0, 0.0, 1.0]], dtype=np.float64)


def intrinsics_after_resize(intrinsic: np.ndarray, scale: float) -> np.ndarray:
    return resize_transform(scale) @ intrinsic


def intrinsics_before_resize(intrinsic: np.ndarray, scale: float) -> np.ndarray:
    """Undo `intrinsics_after_resize`: report intrinsics in the original image's pixels."""
    return np.linalg.inv(resize_transform(scale)) @ intrinsic
