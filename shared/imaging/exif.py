"""Camera intrinsics from a photo's EXIF tags, in the pixels of the upright (orientation-applied) image.

Two sources, the first that is present wins:
- `FocalLengthIn35mmFilm`: the focal length a 36x24 mm film camera would need for the same
  *diagonal* angle of view (CIPA DCG-001), so f_px = f35 * hypot(W, H) / hypot(36, 24).
  It does not depend on the orientation or on the image having been resized.
- `FocalLength` (mm) with `FocalPlaneXResolution` / `FocalPlaneYResolution` (pixels per
  `FocalPlaneResolutionUnit` on the sensor): fx = f_mm * x pixels per mm, scaled by
  width / `PixelXDimension` when the file was resized after the camera wrote the tags.

The principal point is the image centre ((W - 1) / 2, (H - 1) / 2, pixel indices as OpenCV uses).
Orientations 5-8 swap the axes of the stored pixels, so fx and fy swap with them.

A focal length that implies a horizontal field of view outside [MIN_FOV_DEG, MAX_FOV_DEG] is not
used: it is a broken tag, not a camera. Focal length alone (no 35 mm value, no focal-plane
resolution) says nothing in pixels without the sensor size, which EXIF does not carry.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass

import numpy as np
from PIL import ExifTags, Image

ORIENTATION_TAG = 0x0112
FOCAL_LENGTH = 0x920A
FOCAL_LENGTH_35MM = 0xA405
FOCAL_PLANE_X_RESOLUTION = 0xA20E
FOCAL_PLANE_Y_RESOLUTION = 0xA20F
FOCAL_PLANE_RESOLUTION_UNIT = 0xA210
PIXEL_X_DIMENSION = 0xA002
PIXEL_Y_DIMENSION = 0xA003

FILM_DIAGONAL_MM = math.hypot(36.0, 24.0)
# Millimetres per FocalPlaneResolutionUnit: 2 inch and 3 centimetre are the standard's; 4 (mm) and
# 5 (micrometre) are written by some cameras.
_UNIT_MM = {1: 25.4, 2: 25.4, 3: 10.0, 4: 1.0, 5: 0.001}
MIN_FOV_DEG = 1.0
MAX_FOV_DEG = 160.0


@dataclass(frozen=True)
class ExifIntrinsics:
    intrinsic: np.ndarray  # 3x3, pixels of the upright image
    tags: str  # which tags it came from, e.g. "FocalLengthIn35mmFilm=82"

    @property
    def horizontal_fov_deg(self) -> float:
        width = 2.0 * (self.intrinsic[0, 2] + 0.5)
        return math.degrees(2.0 * math.atan(width / (2.0 * self.intrinsic[0, 0])))


def camera_from_exif(data: bytes) -> tuple[ExifIntrinsics | None, str | None]:
    """Intrinsics from an image file's EXIF (header only, pixels are not decoded).

    (intrinsics, None), or (None, why the focal tags present are unusable), or (None, None) when
    the file has no focal tags. Files that cannot be read give (None, None): decoding reports them.
    """
    try:
        with Image.open(io.BytesIO(data)) as image:
            exif = image.getexif()
            size = image.size
    except (OSError, SyntaxError, ValueError):
        return None, None
    return exif_intrinsics(exif, size)


def exif_intrinsics(
    exif: Image.Exif, stored_size: tuple[int, int]
) -> tuple[ExifIntrinsics | None, str | None]:
    """Intrinsics from EXIF tags of an image whose stored pixels are `stored_size` (width, height)."""
    tags = _exif_tags(exif)
    width, height = stored_size
    transposed = _number(tags.get(ORIENTATION_TAG)) in (5, 6, 7, 8)
    focal_35mm = _number(tags.get(FOCAL_LENGTH_35MM))
    if focal_35mm:
        focal = focal_35mm * math.hypot(width, height) / FILM_DIAGONAL_MM
        return _checked(focal, focal, width, height, transposed, f"FocalLengthIn35mmFilm={focal_35mm:g}")
    focal_mm = _number(tags.get(FOCAL_LENGTH))
    x_resolution = _number(tags.get(FOCAL_PLANE_X_RESOLUTION))
    if not focal_mm or not x_resolution:
        return None, None
    y_resolution = _number(tags.get(FOCAL_PLANE_Y_RESOLUTION)) or x_resolution
    unit = int(_number(tags.get(FOCAL_PLANE_RESOLUTION_UNIT)) or 2)
    if unit not in _UNIT_MM:
        return None, f"EXIF FocalPlaneResolutionUnit {unit} is not a known unit"
    # The focal-plane resolution counts pixels of the image as the camera wrote it.
    written_width = _number(tags.get(PIXEL_X_DIMENSION)) or width
    written_height = _number(tags.get(PIXEL_Y_DIMENSION)) or height
    fx = focal_mm * x_resolution / _UNIT_MM[unit] * width / written_width
    fy = focal_mm * y_resolution / _UNIT_MM[unit] * height / written_height
    source = f"FocalLength={focal_mm:g}mm with FocalPlaneXResolution={x_resolution:g}"
    return _checked(fx, fy, width, height, transposed, source)


def _checked(
    fx: float, fy: float, width: int, height: int, transposed: bool, source: str
) -> tuple[ExifIntrinsics | None, str | None]:
    if transposed:
        fx, fy, width, height = fy, fx, height, width
    intrinsic = np.array(
        [[fx, 0.0, (width - 1) / 2.0], [0.0, fy, (height - 1) / 2.0], [0.0, 0.0, 1.0]], dtype=np.float64
    )
    result = ExifIntrinsics(intrinsic=intrinsic, tags=source)
    fov = result.horizontal_fov_deg
    if not (math.isfinite(fov) and MIN_FOV_DEG <= fov <= MAX_FOV_DEG and fx > 0 and fy > 0):
        return None, f"EXIF {source} implies a {fov:.1f} degree field of view, which no camera has"
    return result, None


def _exif_tags(exif: Image.Exif) -> dict[int, object]:
    """Tags of the main IFD and the Exif sub-IFD together (cameras put focal tags in the latter)."""
    tags: dict[int, object] = dict(exif.items())
    try:
        tags.update(exif.get_ifd(ExifTags.IFD.Exif))
    except (KeyError, ValueError, TypeError, OSError):  # a damaged sub-IFD: use what the main one has
        pass
    return tags


def _number(value: object) -> float | None:
    """A positive finite EXIF number (int, IFDRational, or a 1-tuple of them), else None."""
    if isinstance(value, tuple) and len(value) == 1:
        value = value[0]
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    return number if math.isfinite(number) and number > 0 else None


__all__ = ["ExifIntrinsics", "camera_from_exif", "exif_intrinsics"]
