"""Resize views the way the published Pi3 code does, and map results back to the uploaded images.

Every view is resized (LANCZOS, no crop) to one common size: the first image's aspect ratio, at
most `pixel_limit` pixels, both sides multiples of the patch size. A view of another aspect ratio
is stretched, so its x and y scale factors differ; intrinsics and depth maps follow each view's
own factors.

Pixel convention: ours (pixel (u, v) is the integer index, OpenCV) maps to the network image by
u_net + 0.5 = (u + 0.5) * scale_x; the published code's intrinsics put pixel centres at + 0.5, so
a principal point moves by half a pixel between the two.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch
from PIL import Image


def target_size(width: int, height: int, pixel_limit: int = 255_000, patch: int = 14) -> tuple[int, int]:
    """(width, height) the published preprocessing gives a first image of this size."""
    scale = math.sqrt(pixel_limit / (width * height))
    target_w, target_h = width * scale, height * scale
    columns, rows = round(target_w / patch), round(target_h / patch)
    while columns * patch * rows * patch > pixel_limit:
        if columns / rows > target_w / target_h:
            columns -= 1
        else:
            rows -= 1
    return max(1, columns) * patch, max(1, rows) * patch


@dataclass(frozen=True)
class ViewScale:
    original_size: tuple[int, int]  # (width, height) of the uploaded image
    network_size: tuple[int, int]  # (width, height) the model saw

    @property
    def factors(self) -> tuple[float, float]:
        """Network pixels per original pixel along x and y."""
        return (
            self.network_size[0] / self.original_size[0],
            self.network_size[1] / self.original_size[1],
        )

    def intrinsics_to_network(self, intrinsic: np.ndarray) -> np.ndarray:
        """Our 3x3 intrinsics of the uploaded image -> the published convention in network pixels."""
        scale_x, scale_y = self.factors
        k = np.array(intrinsic, dtype=np.float64)
        return np.array(
            [
                [k[0, 0] * scale_x, k[0, 1] * scale_x, (k[0, 2] + 0.5) * scale_x],
                [0.0, k[1, 1] * scale_y, (k[1, 2] + 0.5) * scale_y],
                [0.0, 0.0, 1.0],
            ]
        )

    def network_to_original(self, focal: tuple[float, float], centre: tuple[float, float]) -> np.ndarray:
        """Focal lengths and principal point in network pixels (our convention) -> original intrinsics."""
        scale_x, scale_y = self.factors
        return np.array(
            [
                [focal[0] / scale_x, 0.0, (centre[0] + 0.5) / scale_x - 0.5],
                [0.0, focal[1] / scale_y, (centre[1] + 0.5) / scale_y - 0.5],
                [0.0, 0.0, 1.0],
            ]
        )


def preprocess(
    images: Sequence[np.ndarray], pixel_limit: int = 255_000, patch: int = 14
) -> tuple[torch.Tensor, np.ndarray, list[ViewScale]]:
    """uint8 (H, W, 3) views -> (1, N, 3, H', W') float32 in [0, 1], the resized uint8 views, scales."""
    first_height, first_width = images[0].shape[:2]
    width, height = target_size(first_width, first_height, pixel_limit, patch)
    resized = np.stack(
        [
            np.asarray(Image.fromarray(image).resize((width, height), Image.Resampling.LANCZOS))
            for image in images
        ]
    )
    scales = [ViewScale((image.shape[1], image.shape[0]), (width, height)) for image in images]
    batch = torch.from_numpy(resized).permute(0, 3, 1, 2).float().div(255.0)[None]
    return batch.contiguous(), resized, scales


def resize_depth(depth: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """A depth map (0 or non-finite = unknown) -> (height, width) of `size` by nearest neighbour."""
    depth = np.where(np.isfinite(depth) & (depth > 0), depth, 0.0).astype(np.float32)
    resized = np.asarray(Image.fromarray(depth, mode="F").resize(size, Image.Resampling.NEAREST))
    return np.where(resized > 0, resized, 0.0).astype(np.float32)
