"""The `pi3` and `pi3x` backbones: cameras and dense points of every view in one forward pass.

- Cameras are our convention: 3x4 camera-from-world [R|t], OpenCV axes; intrinsics in pixels of
  each uploaded image (fitted to the predicted camera-frame points, principal point at the image
  centre; or the given ones Pi3X was conditioned on). Depth maps are z-depth over the whole
  uploaded image (on the network's grid) and confidences are in [0, 1] (sigmoid of the logits).
- Units: Pi3X's metric head makes its results metres (`units = "metres"`); Pi3's scale is arbitrary
  (`units = "relative"`). Pi3's world frame is not tied to any view.
- Pi3X takes per view the uploaded or EXIF intrinsics (as rays) and, for posed RGB-D uploads, the
  depths and poses; each view's masks say which it has.
- The model is loaded once per process, on the first reconstruction, and runs one scene at a time.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from contextlib import nullcontext
from typing import Any

import numpy as np
import torch

from services.recon.backbones.base import Backbone, BackboneError, BackboneLoadError, check_rgb_images
from services.recon.backbones.pi3.cameras import extrinsics_from_poses, fit_focal
from services.recon.backbones.pi3.checkpoint import load_pi3
from services.recon.backbones.pi3.config import Arch, Pi3Config, Pi3ConfigError
from services.recon.backbones.pi3.config_file import read_pi3_config
from services.recon.backbones.pi3.inputs import Pi3XInputs, conditioning_inputs
from services.recon.backbones.pi3.preprocessing import ViewScale, preprocess
from services.recon.backbones.transformer.checkpoint import weights_id
from services.recon.checkpoints import CATALOGUE, WeightsError, locate, verify
from shared.geometry.reconstruction import Reconstruction

DEFAULT_CONFIDENCE = 0.1  # points kept where sigmoid(confidence) reaches this (as the published demo)


class Pi3FamilyBackbone(Backbone):
    arch: Arch = "pi3"

    def __init__(
        self,
        checkpoint: str | None = None,
        revision: str = "main",  # of the hub cache, when no checkpoint path is given
        config: str | None = None,
        device: str | None = None,
        confidence_threshold: float = DEFAULT_CONFIDENCE,
        pixel_limit: int = 255_000,
        max_views: int = 64,
    ) -> None:
        try:
            self.config = read_pi3_config(config) if config else Pi3Config.full_size(self.arch)
        except Pi3ConfigError as error:
            raise BackboneError(str(error)) from error
        if self.config.arch != self.arch:
            raise BackboneError(f"config {config} describes {self.config.arch}, not {self.arch}")
        if not 0.0 <= confidence_threshold < 1.0:
            raise BackboneError(f"confidence_threshold must be in [0, 1), not {confidence_threshold}")
        self.units = CATALOGUE[self.name].units
        self.device = torch.device(device or ("cuda" if torch.cuda.is_available() else "cpu"))
        if self.device.type == "cuda" and not torch.cuda.is_available():
            raise BackboneError(f"device {device!r} requested but CUDA is not available")
        self.confidence_threshold = float(confidence_threshold)
        self.pixel_limit, self.max_views = int(pixel_limit), int(max_views)
        self.checkpoint, self.found = locate(self.name, checkpoint, revision)
        self._model: Any = None
        self._load_lock = threading.Lock()
        self._run_lock = threading.Lock()  # one forward pass at a time: each can take gigabytes
        self._check_header(config)
        weights = "absent" if self.checkpoint is None else f"w{weights_id(self.checkpoint)}"
        self.version = f"cfg{self.config.fingerprint()}-{weights}"

    def _check_header(self, config: str | None) -> None:
        """Refuse a safetensors checkpoint whose tensors do not fit, before anything loads it."""
        if self.checkpoint is None or self.checkpoint.suffix.lower() != ".safetensors":
            return
        try:
            problems = verify(self.name, self.checkpoint, config)  # reads the header only
        except WeightsError as error:
            raise BackboneError(str(error)) from error
        if problems:
            raise BackboneError(
                f"checkpoint {self.checkpoint} does not fit {self.name}: " + "; ".join(problems)
            )

    def ready(self) -> tuple[bool, str]:
        if self.checkpoint is None:
            return False, self.found
        state = "loaded" if self._model is not None else "loads on first use"
        return True, f"{self.name} weights from {self.found} ({state}) on {self.device}"

    def model(self) -> Any:
        """The network, loaded from the checkpoint on first use (once per process)."""
        if self.checkpoint is None:
            raise BackboneError(self.found)
        with self._load_lock:
            if self._model is None:
                try:
                    self._model = load_pi3(self.checkpoint, self.config, self.device)
                except BackboneError as error:
                    raise BackboneLoadError(str(error)) from error
            return self._model

    def _autocast(self) -> Any:
        """bf16 (else fp16) autocast on CUDA; plain float32 on the CPU."""
        if self.device.type != "cuda":
            return nullcontext()
        dtype = torch.bfloat16 if torch.cuda.is_bf16_supported() else torch.float16
        return torch.autocast(device_type="cuda", dtype=dtype)

    def check_views(self, images: Sequence[np.ndarray]) -> None:
        check_rgb_images(images, self.name)
        if len(images) > self.max_views:
            raise BackboneError(
                f"{self.name} takes at most {self.max_views} views here (PYSPATIAL_PI3_MAX_VIEWS); "
                f"got {len(images)}"
            )

    def forward(self, batch: torch.Tensor, conditions: Pi3XInputs | None) -> dict[str, np.ndarray]:
        model = self.model()
        extra = conditions.as_kwargs(self.device) if conditions is not None else {}
        with self._run_lock, torch.inference_mode(), self._autocast():
            outputs = model(batch.to(self.device), **extra)
        return {name: value[0].float().cpu().numpy() for name, value in outputs.items()}

    def reconstruct(self, images: Sequence[np.ndarray], **options: Any) -> Reconstruction:
        self.check_views(images)
        batch, resized, scales = preprocess(images, self.pixel_limit, self.config.patch_size)
        conditions, warnings = None, []
        if self.arch == "pi3x":
            conditions, warnings = conditioning_inputs(options, scales, len(images))
        else:
            warnings = [
                f"{self.name} ignores option {name!r}"
                for name in sorted(options)
                if options[name] is not None
            ]
        outputs = self.forward(batch, conditions)
        return self.to_reconstruction(outputs, resized, scales, conditions, warnings)

    def to_reconstruction(
        self,
        outputs: dict[str, np.ndarray],
        resized: np.ndarray,
        scales: list[ViewScale],
        conditions: Pi3XInputs | None,
        warnings: list[str],
    ) -> Reconstruction:
        confidence = 1.0 / (1.0 + np.exp(-outputs["conf"][..., 0].astype(np.float64)))
        poses = outputs["camera_poses"]
        registered = np.isfinite(poses).all(axis=(1, 2))
        intrinsics, sources = self.view_intrinsics(outputs["local_points"], confidence, scales, conditions)
        registered &= np.isfinite(intrinsics).all(axis=(1, 2))
        for index in np.flatnonzero(~registered):
            warnings.append(f"view {index + 1} could not be registered: {self.name} gave no usable camera")
        keep = (confidence >= self.confidence_threshold) & registered[:, None, None]
        keep &= np.isfinite(outputs["points"]).all(axis=-1) & (outputs["local_points"][..., 2] > 0)
        extrinsics = extrinsics_from_poses(poses)
        extrinsics[~registered] = np.nan
        depth = outputs["local_points"][..., 2].astype(np.float32)
        return Reconstruction(
            points=outputs["points"][keep],
            colors=resized[keep],
            point_confidence=confidence[keep].astype(np.float32),  # sigmoid of the logits, 0..1
            extrinsics=extrinsics,
            intrinsics=intrinsics,
            image_sizes=np.array([scale.original_size for scale in scales]),
            registered=registered,
            backbone=self.name,
            backbone_version=self.version,
            depths=[np.where(registered[i], depth[i], 0.0).astype(np.float32) for i in range(len(scales))],
            depth_confidence=[confidence[i].astype(np.float32) for i in range(len(scales))],
            warnings=warnings,
            intrinsics_source=sources,
            units=self.units,
        )

    def view_intrinsics(
        self,
        local_points: np.ndarray,
        confidence: np.ndarray,
        scales: list[ViewScale],
        conditions: Pi3XInputs | None,
    ) -> tuple[np.ndarray, list[str]]:
        """Per view: the given intrinsics Pi3X was conditioned on, else fitted to its points."""
        intrinsics, sources = [], []
        for index, scale in enumerate(scales):
            given = conditions.given_intrinsics(index) if conditions is not None else None
            if given is not None:
                intrinsics.append(given[0])
                sources.append(given[1])
                continue
            weights = np.where(confidence[index] >= self.confidence_threshold, confidence[index], 0.0)
            focal, centre = fit_focal(local_points[index], weights)
            intrinsics.append(scale.network_to_original(focal, centre))
            sources.append("predicted")
        return np.stack(intrinsics), sources


class Pi3Backbone(Pi3FamilyBackbone):
    name = "pi3"
    arch: Arch = "pi3"


class Pi3XBackbone(Pi3FamilyBackbone):
    name = "pi3x"
    arch: Arch = "pi3x"
    accepts_intrinsics = True
    accepts_posed_depth = True
