"""What the recon service knows about a scene's cameras and depth, as Pi3X's conditions.

Per view: intrinsics (uploaded or EXIF, in pixels of the uploaded image) become the ray
condition; a posed RGB-D upload's depths and camera-from-world extrinsics become the depth and
pose conditions. Everything is moved to the network image's pixels (see `preprocessing`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from services.recon.backbones.base import BackboneError
from services.recon.backbones.pi3.preprocessing import ViewScale, resize_depth

KNOWN_OPTIONS = ("intrinsics", "intrinsics_sources", "depths", "extrinsics")


@dataclass
class Pi3XInputs:
    intrinsics: np.ndarray  # (N, 3, 3) network pixels, published convention; placeholders where masked
    ray_mask: np.ndarray  # (N,) bool
    depths: np.ndarray | None  # (N, H, W) network grid, 0 = unknown
    poses: np.ndarray | None  # (N, 4, 4) camera-to-world
    given: list[tuple[np.ndarray, str] | None]  # per view: our intrinsics of the uploaded image, source

    def as_kwargs(self, device: torch.device) -> dict[str, Any]:
        """Keyword arguments of Pi3X.forward (batch axis 1); a condition no view has is left out."""

        def tensor(array: np.ndarray) -> torch.Tensor:
            return torch.from_numpy(np.ascontiguousarray(array, dtype=np.float32))[None].to(device)

        views = len(self.ray_mask)
        kwargs: dict[str, Any] = {}
        if self.ray_mask.any():
            kwargs["intrinsics"] = tensor(self.intrinsics)
        if self.depths is not None:
            kwargs["depths"] = tensor(self.depths)
        if self.poses is not None:
            kwargs["poses"] = tensor(self.poses)
        every = torch.ones(1, views, dtype=torch.bool, device=device)
        ray_mask = torch.from_numpy(self.ray_mask)[None].to(device)
        kwargs["masks"] = (
            every if self.depths is not None else None,
            ray_mask,
            every if self.poses is not None else None,
        )
        return kwargs

    def given_intrinsics(self, index: int) -> tuple[np.ndarray, str] | None:
        return self.given[index]


def _poses_from_extrinsics(extrinsics: np.ndarray) -> np.ndarray:
    """(N, 3|4, 4) camera-from-world -> (N, 4, 4) camera-to-world."""
    matrices = np.zeros((len(extrinsics), 4, 4))
    matrices[:, :3] = np.asarray(extrinsics, dtype=np.float64)[:, :3]
    matrices[:, 3, 3] = 1.0
    return np.linalg.inv(matrices)


def conditioning_inputs(
    options: dict[str, Any], scales: list[ViewScale], views: int
) -> tuple[Pi3XInputs, list[str]]:
    unknown = sorted(set(options) - set(KNOWN_OPTIONS))
    if unknown:
        raise BackboneError(f"pi3x got unknown option(s): {', '.join(unknown)}")
    intrinsics: Sequence[Any] = options.get("intrinsics") or [None] * views
    sources: Sequence[Any] = options.get("intrinsics_sources") or ["uploaded"] * views
    if len(intrinsics) != views or len(sources) != views:
        raise BackboneError(f"pi3x got intrinsics for {len(intrinsics)} views of {views}")
    network, mask, given = [], [], []
    for index, (intrinsic, scale) in enumerate(zip(intrinsics, scales, strict=True)):
        width, height = scale.network_size
        if intrinsic is None or not np.all(np.isfinite(intrinsic)):
            network.append(
                np.array([[width, 0, width / 2], [0, width, height / 2], [0, 0, 1]], dtype=np.float64)
            )
            mask.append(False)
            given.append(None)
            continue
        network.append(scale.intrinsics_to_network(np.asarray(intrinsic, dtype=np.float64)))
        mask.append(True)
        given.append((np.asarray(intrinsic, dtype=np.float64), str(sources[index] or "uploaded")))
    depths, poses, warnings = None, None, []
    if options.get("depths") is not None:
        depths = np.stack(
            [resize_depth(np.asarray(d), scales[i].network_size) for i, d in enumerate(options["depths"])]
        )
    if options.get("extrinsics") is not None:
        poses = _poses_from_extrinsics(np.asarray(options["extrinsics"]))
        if views == 1:
            warnings.append("pi3x: one posed view gives no pose constraint (poses act only relatively)")
    return Pi3XInputs(np.stack(network), np.array(mask, dtype=bool), depths, poses, given), warnings
