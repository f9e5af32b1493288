"""The function the image-decoding processes run; a module of its own so that a worker process
imports only Pillow and numpy (through shared.imaging.codecs), not the web stack."""

from __future__ import annotations

from shared.imaging.codecs import ImageError, decode_image


def validate_image(
    blob: bytes, index: int, max_bytes: int, max_pixels: int
) -> tuple[tuple[int, int] | None, tuple[str, bool] | None]:
    """Decode one image: ((width, height) upright, None), or (None, (message, over_limit)).

    The error travels back as plain values (ImageError's `over_limit` would not survive pickling)
    and is raised again in the service.
    """
    try:
        rgb = decode_image(blob, max_bytes=max_bytes, max_pixels=max_pixels, label=f"image {index + 1}")
    except ImageError as error:
        return None, (str(error), error.over_limit)
    return (int(rgb.shape[1]), int(rgb.shape[0])), None
