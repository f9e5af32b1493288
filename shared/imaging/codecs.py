"""Decode, validate and encode images. Every image entering the system goes through `decode_image`."""

from __future__ import annotations

import base64
import binascii
import io
import warnings

import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError


class ImageError(ValueError):
    """An input image is unusable; the message says why and is safe to show a client."""

    def __init__(self, message: str, over_limit: bool = False) -> None:
        super().__init__(message)
        self.over_limit = over_limit  # too many bytes or pixels (HTTP 413) rather than unreadable


def decode_image(data: bytes, *, max_bytes: int, max_pixels: int, label: str = "image") -> np.ndarray:
    """Bytes of a PNG/JPEG/WebP/TIFF/... file -> upright uint8 RGB (H, W, 3). Raises ImageError.

    - EXIF orientation is applied (phones store portrait photos sideways with a rotate tag).
    - 16-bit greyscale is scaled to 8 bits; floating-point greyscale must lie in [0, 1].
    - Transparency is composited on white, as VGGT's preprocessing does.
    """
    if not data:
        raise ImageError(f"{label} is empty")
    if len(data) > max_bytes:
        raise ImageError(f"{label} is {len(data)} bytes; the limit is {max_bytes}", over_limit=True)
    try:
        with Image.open(io.BytesIO(data)) as probe:
            width, height = probe.size
            if width * height > max_pixels:
                raise ImageError(
                    f"{label} is {width}x{height} pixels; the limit is {max_pixels} pixels", over_limit=True
                )
            with warnings.catch_warnings():
                warnings.simplefilter("error", Image.DecompressionBombWarning)
                probe.load()  # decodes fully: truncated files fail here
            rgb = _to_rgb(ImageOps.exif_transpose(probe), label)
    except ImageError:
        raise
    except UnidentifiedImageError as error:
        if data[:4] in (b"II*\x00", b"MM\x00*"):
            raise ImageError(
                f"{label} is a TIFF this service cannot read (multi-channel floating-point TIFFs are "
                "not supported): convert it to an 8- or 16-bit PNG or TIFF"
            ) from error
        raise ImageError(f"{label} is not an image file this service can read") from error
    except (OSError, SyntaxError, ValueError, Image.DecompressionBombError, Warning) as error:
        raise ImageError(f"{label} could not be decoded: {error}") from error
    if width < 8 or height < 8:
        raise ImageError(f"{label} is {width}x{height}; images must be at least 8x8 pixels")
    return rgb


def header_size(data: bytes, *, max_bytes: int, max_pixels: int, label: str = "image") -> tuple[int, int]:
    """(width, height) read from the file's header only (PIL opens lazily: no pixel is decoded),
    refused with ImageError (over_limit) past the byte or pixel limit. An unreadable header is
    left to `decode_image`, which says why."""
    if len(data) > max_bytes:
        raise ImageError(f"{label} is {len(data)} bytes; the limit is {max_bytes}", over_limit=True)
    try:
        with Image.open(io.BytesIO(data)) as probe:
            width, height = probe.size
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, Image.DecompressionBombError):
        return (0, 0)
    if width * height > max_pixels:
        message = f"{label} is {width}x{height} pixels; the limit is {max_pixels} pixels"
        raise ImageError(message, over_limit=True)
    return width, height


def check_upload_pixels(
    files: list[bytes], *, max_bytes: int, max_pixels: int, max_total_pixels: int
) -> None:
    """Every image within the byte and pixel limits, and all of them within the upload's pixel
    budget, from the headers alone: a 12k x 12k PNG is refused before 430 MB are decoded."""
    sizes = [
        header_size(blob, max_bytes=max_bytes, max_pixels=max_pixels, label=f"image {index + 1}")
        for index, blob in enumerate(files)
    ]
    total = sum(width * height for width, height in sizes)
    if total > max_total_pixels:
        raise ImageError(
            f"the images hold {total} pixels in all; one upload may hold {max_total_pixels}", over_limit=True
        )


def _to_rgb(image: Image.Image, label: str) -> np.ndarray:
    """Any Pillow mode -> uint8 RGB, keeping the brightness the file means."""
    mode = image.mode
    if mode.startswith("I;16") or mode == "I":
        values = np.asarray(image, dtype=np.float64)
        if mode == "I" and (values.min() < 0 or values.max() > 65535):
            raise ImageError(
                f"{label} has 32-bit integer pixels from {values.min():.0f} to {values.max():.0f}; only "
                "8- and 16-bit images are understood"
            )
        return _grey_to_rgb(values / 65535.0)
    if mode == "F":
        values = np.asarray(image, dtype=np.float64)
        if not np.all(np.isfinite(values)):
            raise ImageError(f"{label} is a floating-point image with NaN or infinite pixels")
        low, high = float(values.min()), float(values.max())
        if low < 0.0 or high > 1.0:
            raise ImageError(
                f"{label} is a floating-point image with values from {low:g} to {high:g}; only values "
                "in [0, 1] have a known brightness: convert it to 8 or 16 bits"
            )
        return _grey_to_rgb(values)
    if mode in ("RGBA", "LA", "PA", "La", "RGBa") or (mode == "P" and "transparency" in image.info):
        rgba = image.convert("RGBA")
        white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
        return np.asarray(Image.alpha_composite(white, rgba).convert("RGB"), dtype=np.uint8)
    return np.asarray(image.convert("RGB"), dtype=np.uint8)


def _grey_to_rgb(unit: np.ndarray) -> np.ndarray:
    """Brightness in [0, 1] (H, W) -> uint8 (H, W, 3)."""
    grey = np.clip(np.rint(unit * 255.0), 0, 255).astype(np.uint8)
    return np.repeat(grey[:, :, None], 3, axis=2)


def decode_base64(text: str, label: str = "image") -> bytes:
    """Plain base64 or a data URL -> bytes. Raises ImageError."""
    if text.startswith("data:"):
        text = text.partition(",")[2]
    try:
        return base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError) as error:
        raise ImageError(f"{label} is not valid base64") from error


def encode_image(rgb: np.ndarray, fmt: str = "png", quality: int = 90) -> bytes:
    """uint8 (H, W, 3) -> PNG or JPEG bytes."""
    buffer = io.BytesIO()
    image = Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8), mode="RGB")
    if fmt.lower() in ("jpg", "jpeg"):
        image.save(buffer, format="JPEG", quality=quality)
    elif fmt.lower() == "png":
        image.save(buffer, format="PNG", compress_level=1)  # fast; clues are transient
    else:
        raise ValueError(f"unsupported image format {fmt!r}; use png or jpeg")
    return buffer.getvalue()


def to_data_url(png: bytes, mime: str = "image/png") -> str:
    return f"data:{mime};base64,{base64.b64encode(png).decode('ascii')}"


def media_type(fmt: str) -> str:
    return "image/jpeg" if fmt.lower() in ("jpg", "jpeg") else "image/png"
