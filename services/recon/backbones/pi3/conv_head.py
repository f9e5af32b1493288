"""Pi3X's convolutional dense head: patch features upsampled 2x three times with residual conv
blocks, then resized to the image and turned into per-pixel outputs (UV coordinates fed at each
scale so the convolutions know the aspect ratio).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from services.recon.backbones.pi3.config import ConvHeadSizes
from services.recon.backbones.transformer.layers import uv_grid

GROUP_WIDTH = 32  # the hidden group norm has one group per 32 channels


def conv3x3(in_channels: int, out_channels: int) -> nn.Conv2d:
    return nn.Conv2d(in_channels, out_channels, kernel_size=3, padding=1, padding_mode="replicate")


class ResidualConvBlock(nn.Module):
    def __init__(self, channels: int, hidden: int) -> None:
        super().__init__()
        self.layers = nn.Sequential(
            nn.GroupNorm(1, channels),
            nn.ReLU(),
            conv3x3(channels, hidden),
            nn.GroupNorm(hidden // GROUP_WIDTH, hidden),
            nn.ReLU(),
            conv3x3(hidden, channels),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.layers(x)


def with_uv(x: torch.Tensor, aspect_ratio: float) -> torch.Tensor:
    """Append the 2 UV channels of x's own grid to (B, C, h, w) features."""
    batch, _, height, width = x.shape
    uv = uv_grid(width, height, aspect_ratio, x.dtype, x.device).permute(2, 0, 1)
    return torch.cat((x, uv[None].expand(batch, -1, -1, -1)), dim=1)


class ConvHead(nn.Module):
    def __init__(self, in_dim: int, sizes: ConvHeadSizes, outputs: tuple[int, ...], patch_size: int) -> None:
        super().__init__()
        self.patch_size = patch_size
        widths = (in_dim, *sizes.dim_upsample)
        self.upsample_blocks = nn.ModuleList(
            nn.Sequential(
                nn.Sequential(
                    nn.ConvTranspose2d(c_in + 2, c_out, kernel_size=2, stride=2),
                    conv3x3(c_out, c_out),
                ),
                *(
                    ResidualConvBlock(c_out, sizes.dim_times_res_block_hidden * c_out)
                    for _ in range(sizes.num_res_blocks)
                ),
            )
            for c_in, c_out in zip(widths[:-1], widths[1:], strict=True)
        )
        last, channels = widths[-1] + 2, sizes.last_conv_channels
        self.output_block = nn.ModuleList(
            nn.Sequential(conv3x3(last, channels), nn.ReLU(), nn.Conv2d(channels, out, kernel_size=1))
            for out in outputs
        )

    def forward(self, patches: torch.Tensor, rows: int, columns: int) -> list[torch.Tensor]:
        """(B*N, rows * columns, in_dim) -> one (B*N, channels, H, W) map per output."""
        height, width = rows * self.patch_size, columns * self.patch_size
        x = patches.transpose(1, 2).reshape(patches.shape[0], -1, rows, columns)
        for block in self.upsample_blocks:
            x = block(with_uv(x, width / height))
        x = F.interpolate(x, (height, width), mode="bilinear", align_corners=False)
        x = with_uv(x, width / height)
        return [block(x) for block in self.output_block]
