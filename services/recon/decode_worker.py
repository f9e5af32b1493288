"""The function the image-decoding processes run; a module of its own so that a worker process
imports only Pillow and numpy (through shared.imaging), not the web stack."""

from __future__ import annotations

from shared.imaging import ImageError, decode_image


def validate_image(blob: bytes, index: int, max_bytes: int, max_pixels: int) -> tuple[str, bool] | None:
    """None when the image decodes within the limits, else (message, over_limit) of the ImageError.

    The error travels back as plain values (ImageError's `over_limit` would not survive pickling)
    and is raised again in the service.
    """
    try:
        decode_image(blob, max_bytes=max_bytes, max_pixels=max_pixels, label=f"image {index}")
    except ImageError as error:
        return str(error), error.over_limit
    return None
