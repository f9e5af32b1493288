"""DPT dense head: fuses four aggregator layers into a per-pixel prediction plus a confidence.

VGGT uses two: depth (1 channel, exp activation) and world points (3 channels, signed
log-inverse activation); both predict confidence as 1 + exp(x).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from services.recon.backbones.transformer.layers import uv_grid
from services.recon.backbones.vggt.config import DPTHeadConfig

# Scale of the sinusoidal uv embedding added to the features.
POSITION_EMBEDDING_RATIO = 0.1
DECODER_HIDDEN = 32


def sincos_embedding(values: torch.Tensor, channels: int, omega_0: float = 100.0) -> torch.Tensor:
    """(N,) values -> (N, channels): sines then cosines at geometrically spaced frequencies."""
    exponents = torch.arange(channels // 2, dtype=torch.float64, device=values.device) / (channels / 2.0)
    frequencies = 1.0 / omega_0**exponents
    angles = values.reshape(-1, 1).to(torch.float64) * frequencies
    return torch.cat((angles.sin(), angles.cos()), dim=1).float()


def add_uv_embedding(features: torch.Tensor, image_width: int, image_height: int) -> torch.Tensor:
    """Add a fixed uv position embedding (aspect ratio of the image) to (N, C, h, w) features."""
    channels, height, width = features.shape[1:]
    grid = uv_grid(width, height, image_width / image_height, features.dtype, features.device).reshape(-1, 2)
    embedding = torch.cat(
        (sincos_embedding(grid[:, 0], channels // 2), sincos_embedding(grid[:, 1], channels // 2)), dim=-1
    )
    embedding = embedding.reshape(height, width, channels).permute(2, 0, 1).to(features.dtype)
    return features + POSITION_EMBEDDING_RATIO * embedding[None]


class ResidualConvUnit(nn.Module):
    def __init__(self, features: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(features, features, kernel_size=3, padding=1)
        self.conv2 = nn.Conv2d(features, features, kernel_size=3, padding=1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        # The published unit applies an in-place ReLU to its input, so the skip carries relu(x).
        x = F.relu(x)
        return self.conv2(F.relu(self.conv1(x))) + x


class FusionBlock(nn.Module):
    """Adds a refined skip feature (when it has one), refines, upsamples, projects."""

    def __init__(self, features: int, has_skip: bool = True) -> None:
        super().__init__()
        self.out_conv = nn.Conv2d(features, features, kernel_size=1)
        if has_skip:
            self.resConfUnit1 = ResidualConvUnit(features)
        self.has_skip = has_skip
        self.resConfUnit2 = ResidualConvUnit(features)

    def forward(
        self, x: torch.Tensor, skip: torch.Tensor | None = None, size: tuple[int, int] | None = None
    ) -> torch.Tensor:
        if self.has_skip and skip is not None:
            x = x + self.resConfUnit1(skip)
        x = self.resConfUnit2(x)
        if size is None:
            x = F.interpolate(x, scale_factor=2, mode="bilinear", align_corners=True)
        else:
            x = F.interpolate(x, size=size, mode="bilinear", align_corners=True)
        return self.out_conv(x)


class Scratch(nn.Module):
    """The fusion decoder ('scratch' in the checkpoint's names)."""

    def __init__(self, in_channels: tuple[int, ...], features: int, output_dim: int) -> None:
        super().__init__()
        self.layer1_rn = nn.Conv2d(in_channels[0], features, kernel_size=3, padding=1, bias=False)
        self.layer2_rn = nn.Conv2d(in_channels[1], features, kernel_size=3, padding=1, bias=False)
        self.layer3_rn = nn.Conv2d(in_channels[2], features, kernel_size=3, padding=1, bias=False)
        self.layer4_rn = nn.Conv2d(in_channels[3], features, kernel_size=3, padding=1, bias=False)
        self.refinenet1 = FusionBlock(features)
        self.refinenet2 = FusionBlock(features)
        self.refinenet3 = FusionBlock(features)
        self.refinenet4 = FusionBlock(features, has_skip=False)
        self.output_conv1 = nn.Conv2d(features, features // 2, kernel_size=3, padding=1)
        self.output_conv2 = nn.Sequential(
            nn.Conv2d(features // 2, DECODER_HIDDEN, kernel_size=3, padding=1),
            nn.ReLU(),
            nn.Conv2d(DECODER_HIDDEN, output_dim, kernel_size=1),
        )

    def fuse(self, layers: list[torch.Tensor]) -> torch.Tensor:
        """Coarse to fine fusion of the four resampled layers, then the first output conv."""
        layer1, layer2, layer3, layer4 = (
            self.layer1_rn(layers[0]),
            self.layer2_rn(layers[1]),
            self.layer3_rn(layers[2]),
            self.layer4_rn(layers[3]),
        )
        x = self.refinenet4(layer4, size=layer3.shape[2:])
        x = self.refinenet3(x, layer3, size=layer2.shape[2:])
        x = self.refinenet2(x, layer2, size=layer1.shape[2:])
        x = self.refinenet1(x, layer1)
        return self.output_conv1(x)


def inverse_log_transform(x: torch.Tensor) -> torch.Tensor:
    return torch.sign(x) * torch.expm1(torch.abs(x))


class DPTHead(nn.Module):
    def __init__(self, config: DPTHeadConfig, patch_size: int, output_dim: int, activation: str) -> None:
        super().__init__()
        if activation not in ("exp", "inv_log"):
            raise ValueError(f"unknown DPT activation {activation!r}")
        channels = tuple(config.out_channels)
        self.patch_size = patch_size
        self.activation = activation
        self.layer_indices = tuple(config.intermediate_layer_idx)
        self.frames_chunk_size = config.frames_chunk_size
        self.norm = nn.LayerNorm(config.dim_in)
        self.projects = nn.ModuleList(nn.Conv2d(config.dim_in, c, kernel_size=1) for c in channels)
        # Patch grid resampled to 4x, 2x, 1x and 0.5x: a feature pyramid from one resolution.
        self.resize_layers = nn.ModuleList(
            [
                nn.ConvTranspose2d(channels[0], channels[0], kernel_size=4, stride=4),
                nn.ConvTranspose2d(channels[1], channels[1], kernel_size=2, stride=2),
                nn.Identity(),
                nn.Conv2d(channels[3], channels[3], kernel_size=3, stride=2, padding=1),
            ]
        )
        self.scratch = Scratch(channels, config.features, output_dim)

    def forward(
        self, layers: list[torch.Tensor | None], images: torch.Tensor, patch_start_idx: int
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """-> prediction (B, S, H, W, output_dim - 1) and confidence (B, S, H, W)."""
        frames = images.shape[1]
        step = max(1, self.frames_chunk_size)
        pieces = [
            self._decode(layers, images, patch_start_idx, i, min(i + step, frames))
            for i in range(0, frames, step)
        ]
        return torch.cat([p[0] for p in pieces], dim=1), torch.cat([p[1] for p in pieces], dim=1)

    def _decode(
        self,
        layers: list[torch.Tensor | None],
        images: torch.Tensor,
        patch_start_idx: int,
        start: int,
        end: int,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        batch, _, _, height, width = images.shape
        frames = end - start
        rows, columns = height // self.patch_size, width // self.patch_size
        pyramid = []
        for level, layer_index in enumerate(self.layer_indices):
            tokens = layers[layer_index]
            if tokens is None:
                raise ValueError(f"aggregator layer {layer_index} was not kept")
            tokens = self.norm(
                tokens[:, start:end, patch_start_idx:].reshape(batch * frames, rows * columns, -1)
            )
            grid = tokens.permute(0, 2, 1).reshape(batch * frames, -1, rows, columns)
            grid = add_uv_embedding(self.projects[level](grid), width, height)
            pyramid.append(self.resize_layers[level](grid))
        fused = self.scratch.fuse(pyramid)
        fused = F.interpolate(
            fused,
            size=(rows * self.patch_size, columns * self.patch_size),
            mode="bilinear",
            align_corners=True,
        )
        output = self.scratch.output_conv2(add_uv_embedding(fused, width, height)).permute(0, 2, 3, 1)
        values, confidence = output[..., :-1], output[..., -1]
        values = torch.exp(values) if self.activation == "exp" else inverse_log_transform(values)
        confidence = 1 + torch.exp(confidence)
        return (
            values.reshape(batch, frames, *values.shape[1:]),
            confidence.reshape(batch, frames, *confidence.shape[1:]),
        )
