"""Resize, crop and pad images the way VGGT expects, and remember how to map results back.

Each view goes through: original image -> "resized" image (bicubic, aspect kept, height or width
rounded to a multiple of the patch size) -> a window of it (crop mode may drop top and bottom
rows) -> pasted into the network frame, which is padded with white to the batch's common size.
`ViewPlacement` records those steps so cameras and depth maps can be expressed for the original.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch
from PIL import Image

PreprocessMode = Literal["crop", "pad"]
PAD_VALUE = 1.0  # white, as VGGT was trained


@dataclass(frozen=True)
class ViewPlacement:
    original_size: tuple[int, int]  # (width, height) of the input image
    resized_size: tuple[int, int]  # (width, height) after resizing, before cropping
    crop_origin: tuple[int, int]  # (x, y) of the kept window's top-left corner in the resized image
    content_size: tuple[int, int]  # (width, height) of the kept window
    paste_origin: tuple[int, int]  # (x, y) where the window sits in the network frame

    def resized_scale(self) -> tuple[float, float]:
        """Original pixels per resized pixel along x and y."""
        return (
            self.original_size[0] / self.resized_size[0],
            self.original_size[1] / self.resized_size[1],
        )

    def network_to_original_intrinsics(self, intrinsic: np.ndarray) -> np.ndarray:
        """Intrinsics of the network frame -> intrinsics of the original image (float64)."""
        resized = np.array(intrinsic, dtype=np.float64)
        resized[0, 2] += self.crop_origin[0] - self.paste_origin[0]
        resized[1, 2] += self.crop_origin[1] - self.paste_origin[1]
        scale_x, scale_y = self.resized_scale()
        return np.diag([scale_x, scale_y, 1.0]) @ resized

    def network_window(self) -> tuple[slice, slice]:
        """(rows, columns) of the network frame that show this view's image."""
        (x, y), (width, height) = self.paste_origin, self.content_size
        return slice(y, y + height), slice(x, x + width)

    def resized_window(self) -> tuple[slice, slice]:
        """(rows, columns) of the resized image that the network saw."""
        (x, y), (width, height) = self.crop_origin, self.content_size
        return slice(y, y + height), slice(x, x + width)

    def to_resized_grid(self, network_map: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """A per-pixel map of the network frame -> a map over the whole resized image.

        Rows the crop dropped get `fill` (0 means unknown depth), so the map's grid spans the
        whole original image and intrinsics scale by (map width / width, map height / height).
        """
        width, height = self.resized_size
        out = np.full((height, width, *network_map.shape[2:]), fill, dtype=network_map.dtype)
        out[self.resized_window()] = network_map[self.network_window()]
        return out

    def original_pixels(self) -> tuple[np.ndarray, np.ndarray]:
        """For each pixel of the network window, the nearest original pixel (rows, columns)."""
        rows, columns = self.resized_window()
        scale_x, scale_y = self.resized_scale()
        u = np.floor((np.arange(columns.start, columns.stop) + 0.5) * scale_x).astype(np.int64)
        v = np.floor((np.arange(rows.start, rows.stop) + 0.5) * scale_y).astype(np.int64)
        u = np.clip(u, 0, self.original_size[0] - 1)
        v = np.clip(v, 0, self.original_size[1] - 1)
        return np.meshgrid(v, u, indexing="ij")

    @property
    def dropped_rows(self) -> int:
        return self.resized_size[1] - self.content_size[1]


def _round_to_patch(length: float, patch_size: int) -> int:
    return max(patch_size, round(length / patch_size) * patch_size)


def _resize_plan(
    width: int, height: int, image_size: int, patch_size: int, mode: PreprocessMode
) -> tuple[int, int]:
    if mode == "crop" or width >= height:
        return image_size, _round_to_patch(height * (image_size / width), patch_size)
    return _round_to_patch(width * (image_size / height), patch_size), image_size


def preprocess_images(
    images: Sequence[np.ndarray], image_size: int = 518, patch_size: int = 14, mode: PreprocessMode = "crop"
) -> tuple[torch.Tensor, list[ViewPlacement]]:
    """uint8 (H, W, 3) images -> (S, 3, H', W') float32 RGB in [0, 1] and each view's placement.

    crop: width becomes image_size, height keeps the aspect (rounded to the patch size) and is
    centre-cropped to image_size when taller. pad: the longest side becomes image_size and the
    image is centred on a white image_size square. Views of different shapes are then padded
    (white, centred) to the largest height and width.
    """
    if mode not in ("crop", "pad"):
        raise ValueError(f"preprocess mode must be 'crop' or 'pad', not {mode!r}")
    if image_size % patch_size:
        raise ValueError(f"image size {image_size} is not a multiple of the patch size {patch_size}")
    windows: list[np.ndarray] = []
    plans: list[tuple[tuple[int, int], tuple[int, int], tuple[int, int], tuple[int, int]]] = []
    for image in images:
        height, width = image.shape[:2]
        new_width, new_height = _resize_plan(width, height, image_size, patch_size, mode)
        resized = Image.fromarray(image).resize((new_width, new_height), Image.Resampling.BICUBIC)
        pixels = np.asarray(resized, dtype=np.float32) / 255.0
        crop_y = (new_height - image_size) // 2 if mode == "crop" and new_height > image_size else 0
        window = pixels[crop_y : crop_y + min(new_height, image_size)]
        frame = (image_size, image_size) if mode == "pad" else window.shape[1::-1]
        windows.append(window)
        plans.append(((width, height), (new_width, new_height), (0, crop_y), frame))

    frame_width = max(plan[3][0] for plan in plans)
    frame_height = max(plan[3][1] for plan in plans)
    batch = np.full((len(windows), frame_height, frame_width, 3), PAD_VALUE, dtype=np.float32)
    placements = []
    for index, (window, (original, resized, crop, _)) in enumerate(zip(windows, plans, strict=True)):
        content_height, content_width = window.shape[:2]
        paste = ((frame_width - content_width) // 2, (frame_height - content_height) // 2)
        batch[index, paste[1] : paste[1] + content_height, paste[0] : paste[0] + content_width] = window
        placements.append(ViewPlacement(original, resized, crop, (content_width, content_height), paste))
    return torch.from_numpy(batch).permute(0, 3, 1, 2).contiguous(), placements
