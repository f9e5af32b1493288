"""The `vggt` backbone: feed-forward cameras, depth and points from our VGGT implementation.

Results are in VGGT's normalized scale (the first camera is the world frame). Intrinsics are in
pixels of each original image. Depth and confidence maps cover each whole original image on the
grid of the resized image the network saw (width = image_size in crop mode); rows that crop mode
cut off have depth 0 (unknown) and confidence 0, and a warning says so.

Intrinsics are always VGGT's own prediction (`intrinsics_source` = "predicted"). A predicted
field of view outside [MIN_FOV_DEG, MAX_FOV_DEG] (0 gives an infinite focal length) is no camera:
that view is not registered (NaN pose and intrinsics, no points, no depth) and a warning says so.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch

from services.recon.backbones.base import Backbone, BackboneError, check_rgb_images
from services.recon.backbones.transformer.checkpoint import weights_id
from services.recon.backbones.vggt.checkpoint import load_vggt
from services.recon.backbones.vggt.config import VGGTConfig, VGGTConfigError
from services.recon.backbones.vggt.geometry import pose_encoding_to_cameras, unproject_depth_maps
from services.recon.backbones.vggt.model import VGGT
from services.recon.backbones.vggt.preprocessing import PreprocessMode, ViewPlacement, preprocess_images
from shared.geometry.reconstruction import Reconstruction

PointSource = Literal["depth", "points"]
MIN_CONFIDENCE = 1e-5  # confidences are 1 + exp(x) >= 1; anything below is padding or garbage
MIN_FOV_DEG, MAX_FOV_DEG = 1.0, 175.0  # a predicted field of view outside these is no camera


class VGGTBackbone(Backbone):
    name = "vggt"

    def __init__(
        self,
        checkpoint: str | None = None,
        config: str | None = None,
        device: str | None = None,
        point_source: PointSource = "depth",
        confidence_percentile: float = 50.0,
        preprocess_mode: PreprocessMode = "crop",
        image_size: int | None = None,
    ) -> None:
        try:
            self.config = VGGTConfig.from_json(config) if config else VGGTConfig()
        except VGGTConfigError as error:
            raise BackboneError(str(error)) from error
        if point_source not in ("depth", "points"):
            raise BackboneError(f"point_source must be 'depth' or 'points', not {point_source!r}")
        if preprocess_mode not in ("crop", "pad"):
            raise BackboneError(f"preprocess_mode must be 'crop' or 'pad', not {preprocess_mode!r}")
        if not 0.0 <= float(confidence_percentile) <= 100.0:
            raise BackboneError(f"confidence_percentile must be in [0, 100], not {confidence_percentile}")
        self.image_size = int(image_size or self.config.img_size)
        if self.image_size % self.config.patch_size or self.image_size <= 0:
            raise BackboneError(f"image_size {self.image_size} is not a multiple of {self.config.patch_size}")
        self.point_source: PointSource = point_source
        self.confidence_percentile = float(confidence_percentile)
        self.preprocess_mode: PreprocessMode = preprocess_mode
        self.device = torch.device(device or ("cuda" if torch.cuda.is_available() else "cpu"))
        if self.device.type == "cuda" and not torch.cuda.is_available():
            raise BackboneError(f"device {device!r} requested but CUDA is not available")
        self.checkpoint = checkpoint
        self._model: VGGT | None = None
        self._lock = threading.Lock()  # one forward pass at a time: each can take gigabytes
        self.version = f"cfg{self.config.fingerprint()}-unloaded"
        if checkpoint:
            self._model = load_vggt(checkpoint, self.config, self.device)
            self.version = f"cfg{self.config.fingerprint()}-w{weights_id(checkpoint)}"

    def ready(self) -> tuple[bool, str]:
        if self._model is None:
            return False, "no VGGT checkpoint configured (pass checkpoint=path to a .pt or .safetensors file)"
        return True, f"VGGT loaded from {Path(str(self.checkpoint)).name} on {self.device}"

    # ---- inference ---------------------------------------------------------------------------

    def _autocast(self) -> Any:
        """bf16 autocast where the GPU supports it; plain float32 elsewhere."""
        if self.device.type == "cuda" and torch.cuda.is_bf16_supported():
            return torch.autocast(device_type="cuda", dtype=torch.bfloat16)
        return nullcontext()

    def predict(self, images: Sequence[np.ndarray]) -> tuple[dict[str, np.ndarray], list[ViewPlacement]]:
        """Raw network outputs for one scene (network frame, batch dimension removed) and placements."""
        if self._model is None:
            raise BackboneError(self.ready()[1])
        batch, placements = preprocess_images(
            images, self.image_size, self.config.patch_size, self.preprocess_mode
        )
        with self._lock, torch.inference_mode(), self._autocast():
            outputs = self._model(batch.to(self.device))
            extrinsics, intrinsics = pose_encoding_to_cameras(outputs["pose_enc"], tuple(batch.shape[-2:]))
        arrays = {name: value[0].float().cpu().numpy() for name, value in outputs.items()}
        arrays["extrinsic"] = extrinsics[0].float().cpu().numpy()
        arrays["intrinsic"] = intrinsics[0].float().cpu().numpy()
        return arrays, placements

    def reconstruct(self, images: Sequence[np.ndarray], **options: Any) -> Reconstruction:
        check_rgb_images(images, self.name)
        point_source = options.pop("point_source", self.point_source)
        percentile = float(options.pop("confidence_percentile", self.confidence_percentile))
        if point_source not in ("depth", "points") or not 0.0 <= percentile <= 100.0:
            raise BackboneError(
                f"bad options point_source={point_source!r} confidence_percentile={percentile}"
            )
        warnings = [f"vggt ignores option {name!r}" for name in sorted(options)]
        arrays, placements = self.predict(images)
        frame_hw = arrays["depth"].shape[1:3]
        problems = [_field_of_view_problem(intrinsic, frame_hw) for intrinsic in arrays["intrinsic"]]
        usable = np.array([problem is None for problem in problems])
        if not usable.any():
            raise BackboneError(f"VGGT gave no usable camera: {problems[0]} (and likewise for every view)")
        for index, problem in enumerate(problems):
            if problem is not None:
                warnings.append(f"view {index + 1} could not be registered: VGGT predicted {problem}")
        if point_source == "depth":
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):  # bad views are dropped
                world = unproject_depth_maps(arrays["depth"], arrays["extrinsic"], arrays["intrinsic"])
            confidence = arrays["depth_conf"]
        else:
            world, confidence = arrays["world_points"], arrays["world_points_conf"]
        points, colors, scores = _confident_points(
            world, confidence, arrays["depth"][..., 0], images, placements, percentile, usable
        )

        depths, depth_confidence, intrinsics = [], [], []
        for index, placement in enumerate(placements):
            depths.append(placement.to_resized_grid(arrays["depth"][index, ..., 0]))
            depth_confidence.append(placement.to_resized_grid(arrays["depth_conf"][index]))
            if usable[index]:
                intrinsics.append(placement.network_to_original_intrinsics(arrays["intrinsic"][index]))
            else:  # no camera: its depth cannot be placed either
                intrinsics.append(np.full((3, 3), np.nan))
                depths[-1] = np.zeros_like(depths[-1])
                depth_confidence[-1] = np.zeros_like(depth_confidence[-1])
            if placement.dropped_rows:
                warnings.append(
                    f"view {index + 1}: {placement.dropped_rows} of {placement.resized_size[1]} resized rows "
                    "fell outside VGGT's centre crop and have no depth"
                )
        extrinsics = arrays["extrinsic"].astype(np.float64)
        extrinsics[~usable] = np.nan
        return Reconstruction(
            points=points,
            colors=colors,
            extrinsics=extrinsics,
            intrinsics=np.stack(intrinsics),
            image_sizes=np.array([p.original_size for p in placements]),
            registered=usable,
            backbone=self.name,
            backbone_version=self.version,
            depths=depths,
            depth_confidence=depth_confidence,
            warnings=warnings,
            intrinsics_source=["predicted"] * len(placements),
            point_confidence=scores,
        )


def _field_of_view_problem(intrinsic: np.ndarray, frame_hw: tuple[int, int]) -> str | None:
    """Why a predicted network-frame intrinsic is no camera (e.g. a zero field of view), or None."""
    height, width = frame_hw
    fx, fy = float(intrinsic[0, 0]), float(intrinsic[1, 1])
    fovs = []
    for focal, size in ((fx, width), (fy, height)):
        if not np.isfinite(focal) or focal <= 0:
            return "a zero field of view (infinite focal length)"
        fovs.append(float(np.degrees(2.0 * np.arctan(size / (2.0 * focal)))))
    if not all(MIN_FOV_DEG <= fov <= MAX_FOV_DEG for fov in fovs):
        return f"an implausible field of view ({fovs[0]:.2f} x {fovs[1]:.2f} degrees)"
    return None


def _confident_points(
    world: np.ndarray,
    confidence: np.ndarray,
    depth: np.ndarray,
    images: Sequence[np.ndarray],
    placements: list[ViewPlacement],
    percentile: float,
    usable: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points of every usable view's image window whose confidence reaches the given percentile,
    their colours and their confidence.

    The percentile is taken over all views' valid pixels together, so confident views keep more.
    """
    points, colors, scores = [], [], []
    for index, placement in enumerate(placements):
        if not usable[index]:
            continue
        window = placement.network_window()
        view_points = world[index][window].reshape(-1, 3)
        view_scores = confidence[index][window].reshape(-1)
        valid = (
            np.isfinite(view_points).all(axis=1)
            & np.isfinite(view_scores)
            & (view_scores > MIN_CONFIDENCE)
            & (depth[index][window].reshape(-1) > 0)
        )
        rows, columns = placement.original_pixels()
        points.append(view_points[valid])
        colors.append(images[index][rows, columns].reshape(-1, 3)[valid])
        scores.append(view_scores[valid])
    all_points, all_colors, all_scores = (
        np.concatenate(points),
        np.concatenate(colors),
        np.concatenate(scores),
    )
    if len(all_scores) == 0:
        return all_points.astype(np.float32), all_colors, all_scores.astype(np.float32)
    keep = all_scores >= np.percentile(all_scores, percentile)
    return all_points[keep].astype(np.float32), all_colors[keep], all_scores[keep].astype(np.float32)
