"""Decode, validate and encode images. Every image entering the system goes through `decode_image`."""

from __future__ import annotations

import base64
import binascii
import io
import warnings

import numpy as np
from PIL import Image, UnidentifiedImageError


class ImageError(ValueError):
    """An input image is unusable; the message says why and is safe to show a client."""

    def __init__(self, message: str, over_limit: bool = False) -> None:
        super().__init__(message)
        self.over_limit = over_limit  # too many bytes or pixels (HTTP 413) rather than unreadable


def decode_image(data: bytes, *, max_bytes: int, max_pixels: int, label: str = "image") -> np.ndarray:
    """Bytes of a PNG/JPEG/WebP/... file -> uint8 RGB (H, W, 3). Raises ImageError."""
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
            rgb = probe.convert("RGB")
    except ImageError:
        raise
    except UnidentifiedImageError as error:
        raise ImageError(f"{label} is not an image file this service can read") from error
    except (OSError, SyntaxError, ValueError, Image.DecompressionBombError, Warning) as error:
        raise ImageError(f"{label} could not be decoded: {error}") from error
    if width < 8 or height < 8:
        raise ImageError(f"{label} is {width}x{height}; images must be at least 8x8 pixels")
    return np.asarray(rgb, dtype=np.uint8)


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
