"""A backbone for views whose cameras and depth are already known (RGB-D sensors, synthetic scenes).

It estimates nothing: it fuses the given depth maps into a coloured cloud, which makes it exact and
a reference for the learned backbones.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from services.recon.backbones.base import Backbone, BackboneError
from shared.geometry.backprojection import reconstruction_from_rgbd
from shared.geometry.reconstruction import Reconstruction

REQUIRED_OPTIONS = ("depths", "extrinsics", "intrinsics")
OPTIONAL_OPTIONS = ("stride",)


class PosedRGBDBackbone(Backbone):
    name = "posed-rgbd"
    version = "1"

    def __init__(self, stride: int = 1) -> None:
        if stride < 1:
            raise BackboneError(f"stride must be >= 1, got {stride}")
        self.stride = stride

    def reconstruct(self, images: Sequence[np.ndarray], **options: Any) -> Reconstruction:
        """Options: depths (per view (h, w) z-depth), extrinsics (V, 3|4, 4), intrinsics (V, 3, 3)
        in image pixels, and optionally stride (sample every stride-th depth pixel)."""
        unknown = sorted(set(options) - set(REQUIRED_OPTIONS) - set(OPTIONAL_OPTIONS))
        if unknown:
            raise BackboneError(f"posed-rgbd got unknown option(s): {', '.join(unknown)}")
        missing = [name for name in REQUIRED_OPTIONS if options.get(name) is None]
        if missing:
            raise BackboneError(
                "posed-rgbd needs depths, extrinsics and intrinsics for every view; "
                f"missing: {', '.join(missing)}"
            )
        try:
            return reconstruction_from_rgbd(
                images,
                options["depths"],
                options["extrinsics"],
                options["intrinsics"],
                stride=int(options.get("stride", self.stride)),
                backbone=self.name,
                version=self.version,
            )
        except ValueError as error:
            raise BackboneError(f"posed-rgbd cannot use its input: {error}") from error
