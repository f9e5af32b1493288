"""VGGT: images of one scene -> cameras, depth maps and world point maps in one forward pass."""

from __future__ import annotations

import torch
from torch import nn

from services.recon.backbones.vggt.aggregator import Aggregator
from services.recon.backbones.vggt.camera_head import CameraHead
from services.recon.backbones.vggt.config import VGGTConfig
from services.recon.backbones.vggt.dpt_head import DPTHead


class VGGT(nn.Module):
    """The published architecture without its tracking head.

    Submodule names are the checkpoint's (aggregator, camera_head, depth_head, point_head), so a
    published state dict loads with no renaming.
    """

    def __init__(self, config: VGGTConfig | None = None) -> None:
        super().__init__()
        self.config = config or VGGTConfig()
        self.aggregator = Aggregator(self.config)
        self.camera_head = CameraHead(self.config.camera_head)
        self.point_head = DPTHead(self.config.dpt_head, self.config.patch_size, 4, activation="inv_log")
        self.depth_head = DPTHead(self.config.dpt_head, self.config.patch_size, 2, activation="exp")

    def forward(self, images: torch.Tensor) -> dict[str, torch.Tensor]:
        """images: (S, 3, H, W) or (B, S, 3, H, W) RGB in [0, 1], H and W multiples of the patch size.

        Returns pose_enc (B, S, 9), depth (B, S, H, W, 1), depth_conf (B, S, H, W),
        world_points (B, S, H, W, 3) and world_points_conf (B, S, H, W).
        """
        if images.ndim == 4:
            images = images[None]
        height, width = images.shape[-2:]
        patch = self.config.patch_size
        if height % patch or width % patch:
            raise ValueError(f"image size {width}x{height} is not a multiple of the patch size {patch}")
        last = self.config.depth - 1
        layers = self.aggregator(images, keep={last, *self.config.dpt_head.intermediate_layer_idx})
        start = self.aggregator.patch_start_idx
        # The heads run in float32 even under mixed precision, as published.
        with torch.autocast(device_type=images.device.type, enabled=False):
            layers = [None if layer is None else layer.float() for layer in layers]
            images = images.float()
            pose_encodings = self.camera_head(layers[last])
            depth, depth_conf = self.depth_head(layers, images, start)
            points, points_conf = self.point_head(layers, images, start)
        return {
            "pose_enc": pose_encodings[-1],
            "depth": depth,
            "depth_conf": depth_conf,
            "world_points": points,
            "world_points_conf": points_conf,
        }
