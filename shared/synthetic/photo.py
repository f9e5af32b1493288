"""Rendered views saved as a camera saves photos: PNG with the focal length in EXIF.

A real camera states its focal length (`FocalLengthIn35mmFilm`); without it, two views cannot
fix the focal and the classical backbone refuses to guess their relative pose. The renderer knows
its camera exactly, so it says so the same way, and the recon service reads it like any photo's
(shared/imaging/exif.py). The tag is a whole number of millimetres: a 60-degree camera is written
as 30 mm, read back within 0.1% of the true focal.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
from PIL import ExifTags, Image

from shared.imaging.exif import FILM_DIAGONAL_MM, FOCAL_LENGTH_35MM


def focal_35mm(intrinsic: np.ndarray, width: int, height: int) -> int:
    """The 35 mm equivalent focal length (diagonal angle of view) of a pinhole camera."""
    return max(1, round(float(intrinsic[0, 0]) * FILM_DIAGONAL_MM / math.hypot(width, height)))


def photo_exif(intrinsic: np.ndarray, width: int, height: int) -> Image.Exif:
    exif = Image.Exif()
    exif.get_ifd(ExifTags.IFD.Exif)[FOCAL_LENGTH_35MM] = focal_35mm(intrinsic, width, height)
    return exif


def save_photo(target: str | Path | io.BytesIO, rgb: np.ndarray, intrinsic: np.ndarray) -> None:
    height, width = rgb.shape[:2]
    # Pillow's PNG writer writes the eXIf chunk only from bytes (an Exif object is dropped).
    Image.fromarray(rgb).save(target, format="PNG", exif=photo_exif(intrinsic, width, height).tobytes())


def photo_bytes(rgb: np.ndarray, intrinsic: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    save_photo(buffer, rgb, intrinsic)
    return buffer.getvalue()
