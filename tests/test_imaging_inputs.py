"""Images as cameras took them: EXIF orientation, 16-bit and float pixels, transparency, EXIF focal length."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from PIL import Image

from shared.imaging.codecs import ImageError, decode_image
from shared.imaging.exif import camera_from_exif

LIMITS = {"max_bytes": 2**26, "max_pixels": 2**24}
EXIF_IFD = 0x8769
ORIENTATION = 0x0112

# What exif_transpose must undo: the stored pixels are the upright image transposed like this.
STORED_FROM_UPRIGHT = {
    1: None,
    2: Image.Transpose.FLIP_LEFT_RIGHT,
    3: Image.Transpose.ROTATE_180,
    4: Image.Transpose.FLIP_TOP_BOTTOM,
    5: Image.Transpose.TRANSPOSE,
    6: Image.Transpose.ROTATE_90,
    7: Image.Transpose.TRANSVERSE,
    8: Image.Transpose.ROTATE_270,
}


def upright_image(width: int = 48, height: int = 32) -> np.ndarray:
    """Asymmetric content, so that every flip and rotation gives a different array."""
    v, u = np.mgrid[0:height, 0:width]
    rgb = np.stack([u * 255 // (width - 1), v * 255 // (height - 1), (u * v) % 251], axis=-1)
    rgb[:6, :10] = (250, 10, 10)  # a red corner: top-left when upright
    return rgb.astype(np.uint8)


def encoded(image: Image.Image, fmt: str = "PNG", **options) -> bytes:
    buffer = io.BytesIO()
    image.save(buffer, format=fmt, **options)
    return buffer.getvalue()


def exif_with(orientation: int | None = None, **exif_tags: float) -> Image.Exif:
    exif = Image.Exif()
    if orientation is not None:
        exif[ORIENTATION] = orientation
    tags = {"focal_35mm": 0xA405, "focal_mm": 0x920A, "x_res": 0xA20E, "y_res": 0xA20F, "unit": 0xA210,
            "pixel_x": 0xA002, "pixel_y": 0xA003}  # fmt: skip
    for name, value in exif_tags.items():
        exif.get_ifd(EXIF_IFD)[tags[name]] = value
    return exif


@pytest.mark.parametrize("orientation", range(1, 9))
def test_exif_orientation_is_applied(orientation: int) -> None:
    upright = upright_image()
    stored = Image.fromarray(upright)
    if STORED_FROM_UPRIGHT[orientation] is not None:
        stored = stored.transpose(STORED_FROM_UPRIGHT[orientation])
    data = encoded(stored, exif=exif_with(orientation))
    np.testing.assert_array_equal(decode_image(data, **LIMITS), upright)


def test_sixteen_bit_greyscale_keeps_its_brightness() -> None:
    ramp = np.linspace(0, 65535, 64 * 40).reshape(40, 64).astype(np.uint16)
    data = encoded(Image.fromarray(ramp))  # Pillow writes a 16-bit greyscale PNG
    assert Image.open(io.BytesIO(data)).mode.startswith("I")
    rgb = decode_image(data, **LIMITS)
    expected = np.rint(ramp / 257.0).astype(np.uint8)
    np.testing.assert_array_equal(rgb[..., 0], expected)
    np.testing.assert_array_equal(rgb[..., 0], rgb[..., 2])
    assert rgb.min() == 0 and rgb.max() == 255  # not all white


def test_float_tiff_in_unit_range_is_scaled() -> None:
    values = np.linspace(0.0, 1.0, 64 * 40, dtype=np.float32).reshape(40, 64)
    rgb = decode_image(encoded(Image.fromarray(values, mode="F"), "TIFF"), **LIMITS)
    np.testing.assert_array_equal(rgb[..., 1], np.rint(values * 255).astype(np.uint8))
    assert rgb.max() == 255  # not all black


@pytest.mark.parametrize(
    ("values", "message"),
    [(np.full((16, 16), 300.0), "from 300 to 300"), (np.full((16, 16), np.nan), "NaN")],
    ids=["out-of-range", "nan"],
)
def test_float_tiff_without_known_brightness_is_refused(values: np.ndarray, message: str) -> None:
    data = encoded(Image.fromarray(values.astype(np.float32), mode="F"), "TIFF")
    with pytest.raises(ImageError, match=message):
        decode_image(data, **LIMITS)


def test_transparency_is_composited_on_white() -> None:
    rgba = np.zeros((20, 30, 4), np.uint8)
    rgba[..., :3] = (10, 120, 30)
    rgba[..., 3] = 255
    rgba[:, :10, 3] = 0  # fully transparent
    rgba[:, 10:20, 3] = 128  # half
    rgb = decode_image(encoded(Image.fromarray(rgba, mode="RGBA")), **LIMITS)
    assert (rgb[:, :10] == 255).all()
    np.testing.assert_allclose(rgb[0, 15], (132, 187, 142), atol=2)  # halfway to white
    assert tuple(rgb[0, 25]) == (10, 120, 30)
    indices = np.zeros((20, 30), np.uint8)
    indices[:, 15:] = 1  # palette entry 1 is transparent
    palette = Image.fromarray(indices, mode="P")
    palette.putpalette([10, 120, 30, 200, 0, 0] + [0, 0, 0] * 254)
    decoded = decode_image(encoded(palette, transparency=1), **LIMITS)
    assert (decoded[:, 15:] == 255).all() and tuple(decoded[0, 0]) == (10, 120, 30)


def test_35mm_equivalent_focal_length_gives_pixels_by_the_diagonal() -> None:
    data = encoded(Image.fromarray(upright_image(640, 480)), "JPEG", exif=exif_with(1, focal_35mm=82))
    intrinsics, note = camera_from_exif(data)
    assert note is None
    focal = 82 * 800 / math.hypot(36, 24)
    np.testing.assert_allclose(intrinsics.intrinsic, [[focal, 0, 319.5], [0, focal, 239.5], [0, 0, 1]])
    assert intrinsics.tags == "FocalLengthIn35mmFilm=82"


def test_focal_plane_resolution_rotates_with_the_orientation() -> None:
    # 5 mm lens, 200 px/mm across and 100 px/mm down the sensor (non-square to see the swap), stored
    # 64x32 but written by the camera as 128x64: the file was halved since.
    tags = {"focal_mm": 5.0, "x_res": 200.0, "y_res": 100.0, "unit": 4, "pixel_x": 128, "pixel_y": 64}
    stored = Image.fromarray(upright_image(64, 32))
    plain, _ = camera_from_exif(encoded(stored, "JPEG", exif=exif_with(1, **tags)))
    np.testing.assert_allclose(np.diag(plain.intrinsic)[:2], [500.0, 250.0])
    np.testing.assert_allclose(plain.intrinsic[:2, 2], [31.5, 15.5])
    turned, _ = camera_from_exif(encoded(stored, "JPEG", exif=exif_with(6, **tags)))
    np.testing.assert_allclose(np.diag(turned.intrinsic)[:2], [250.0, 500.0])  # upright: 32 wide, 64 high
    np.testing.assert_allclose(turned.intrinsic[:2, 2], [15.5, 31.5])


def test_unusable_or_missing_focal_tags() -> None:
    image = Image.fromarray(upright_image(64, 48))
    assert camera_from_exif(encoded(image)) == (None, None)
    assert camera_from_exif(encoded(image, "JPEG", exif=exif_with(1, focal_mm=4.2))) == (None, None)
    intrinsics, note = camera_from_exif(encoded(image, "JPEG", exif=exif_with(1, focal_35mm=1)))
    assert intrinsics is None and "field of view" in note
    assert camera_from_exif(b"not an image") == (None, None)
