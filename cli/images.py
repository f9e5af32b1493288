"""Turn the IMAGES arguments of a command into an ordered list of image files."""

from __future__ import annotations

from pathlib import Path

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".webp", ".tif", ".tiff"}


def collect_images(arguments: list[Path]) -> list[Path]:
    """Files as given, in order; or the images of one folder, sorted by name.

    Raises ValueError with a message fit for the user when nothing usable was named.
    """
    if not arguments:
        raise ValueError("name one folder or one or more image files")
    if len(arguments) == 1 and arguments[0].is_dir():
        folder = arguments[0]
        found = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
        if not found:
            raise ValueError(f"no images ({', '.join(sorted(IMAGE_SUFFIXES))}) in {folder}")
        return found
    for path in arguments:
        if path.is_dir():
            raise ValueError(f"{path} is a folder: give either one folder or image files, not both")
        if not path.is_file():
            raise ValueError(f"no such file: {path}")
    return list(arguments)
