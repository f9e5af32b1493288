"""The backbone interface and a registry that picks one by name from configuration."""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from shared.geometry.reconstruction import Reconstruction


class BackboneError(RuntimeError):
    """A backbone cannot run (bad configuration, missing checkpoint) or cannot use the input."""


class BackboneLoadError(BackboneError):
    """A backbone's weights could not be loaded when it first ran (an installation fault, not the input's)."""


class Backbone(ABC):
    """Turns RGB images of one scene into a `Reconstruction`.

    `reconstruct` gets uint8 (H, W, 3) arrays; sizes may differ between views. A view that cannot
    be placed is reported with `registered[i] = False` and a warning, never with an invented pose.
    """

    name: str = ""
    version: str = ""
    # True when `reconstruct` takes `intrinsics` (per view a 3x3 in the image's pixels, or None)
    # and `intrinsics_sources` (per view "uploaded" / "exif", or None) and uses them.
    accepts_intrinsics: bool = False
    # True when `reconstruct` also takes a posed RGB-D upload's `depths` (per view (h, w) z-depth)
    # and `extrinsics` ((V, 3, 4) camera-from-world) as conditions.
    accepts_posed_depth: bool = False

    @abstractmethod
    def reconstruct(self, images: Sequence[np.ndarray], **options: Any) -> Reconstruction: ...

    def ready(self) -> tuple[bool, str]:
        """Whether the backbone can serve now, and why not."""
        return True, "ok"


def check_rgb_images(images: Sequence[np.ndarray], backbone: str) -> None:
    """At least one image, each a uint8 (H, W, 3) RGB array at least 2 pixels on a side."""
    if len(images) == 0:
        raise BackboneError(f"{backbone} needs at least one image")
    for index, image in enumerate(images):
        if (
            not isinstance(image, np.ndarray)
            or image.dtype != np.uint8
            or image.ndim != 3
            or image.shape[2] != 3
        ):
            raise BackboneError(f"image {index + 1} is not a uint8 (H, W, 3) RGB array")
        if min(image.shape[:2]) < 2:
            raise BackboneError(f"image {index + 1} is too small: {image.shape[1]}x{image.shape[0]}")


# name -> "module:factory"; imported lazily so that e.g. torch loads only for backbones that need it.
_REGISTRY: dict[str, str] = {
    "classical": "services.recon.backbones.classical:ClassicalBackbone",
    "posed-rgbd": "services.recon.backbones.posed_rgbd:PosedRGBDBackbone",
    "vggt": "services.recon.backbones.vggt.backbone:VGGTBackbone",
    "pi3": "services.recon.backbones.pi3.backbone:Pi3Backbone",
    "pi3x": "services.recon.backbones.pi3.backbone:Pi3XBackbone",
}


def register_backbone(name: str, target: str) -> None:
    _REGISTRY[name] = target


def available_backbones() -> list[str]:
    return sorted(_REGISTRY)


def create_backbone(name: str, **settings: Any) -> Backbone:
    """Instantiate a registered backbone; settings are passed to its constructor."""
    if name not in _REGISTRY:
        raise BackboneError(f"unknown backbone {name!r}; available: {', '.join(available_backbones())}")
    module_name, _, attribute = _REGISTRY[name].partition(":")
    try:
        factory: Callable[..., Backbone] = getattr(importlib.import_module(module_name), attribute)
    except (ImportError, AttributeError) as error:  # a broken install must not take the service down
        raise BackboneError(f"backbone {name!r} cannot be loaded: {error}") from error
    return factory(**settings)
