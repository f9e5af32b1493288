"""DINOv2 vision transformer with register tokens: VGGT's patch embedder, Pi3's image (and depth) encoder."""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from services.recon.backbones.transformer.layers import Block


@dataclass(frozen=True)
class DinoV2Sizes:
    """The numbers that make one DINOv2-with-registers encoder (defaults: ViT-L/14 with 4 registers)."""

    embed_dim: int = 1024
    depth: int = 24
    num_heads: int = 16
    mlp_ratio: float = 4.0
    init_values: float = 1.0
    img_size: int = 518  # the position table covers (img_size / patch_size)^2 patches
    patch_size: int = 14
    num_register_tokens: int = 4
    interpolate_antialias: bool = True
    interpolate_offset: float = 0.0
    in_chans: int = 3  # Pi3X's depth encoder reads 2 channels (depth, validity)
    mask_token: bool = True  # VGGT's checkpoint keeps DINOv2's training-only mask token; Pi3's does not


class PatchProjection(nn.Module):
    """Non-overlapping patch_size x patch_size convolution: image -> (B, patches, dim)."""

    def __init__(self, patch_size: int, embed_dim: int, in_chans: int = 3) -> None:
        super().__init__()
        self.proj = nn.Conv2d(in_chans, embed_dim, kernel_size=patch_size, stride=patch_size)

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        return self.proj(images).flatten(2).transpose(1, 2)


class DinoV2WithRegisters(nn.Module):
    def __init__(self, sizes: DinoV2Sizes) -> None:
        super().__init__()
        dim = sizes.embed_dim
        self.sizes = sizes
        self.patch_size = sizes.patch_size
        self.grid_side = sizes.img_size // sizes.patch_size
        self.patch_embed = PatchProjection(sizes.patch_size, dim, sizes.in_chans)
        self.cls_token = nn.Parameter(torch.zeros(1, 1, dim))
        self.pos_embed = nn.Parameter(torch.zeros(1, self.grid_side**2 + 1, dim))
        self.register_tokens = nn.Parameter(torch.zeros(1, sizes.num_register_tokens, dim))
        if sizes.mask_token:
            # Used by DINOv2 only for masked-image training; kept so the checkpoint loads unchanged.
            self.mask_token = nn.Parameter(torch.zeros(1, dim), requires_grad=False)
        self.blocks = nn.ModuleList(
            Block(dim, sizes.num_heads, sizes.mlp_ratio, sizes.init_values, norm_eps=1e-6)
            for _ in range(sizes.depth)
        )
        self.norm = nn.LayerNorm(dim, eps=1e-6)
        self.num_register_tokens = sizes.num_register_tokens

    def position_embedding(self, rows: int, columns: int) -> torch.Tensor:
        """The class token's embedding and the patch grid's, resampled to rows x columns (bicubic)."""
        side = self.grid_side
        if rows == side and columns == side:
            return self.pos_embed
        table = self.pos_embed.float()
        grid = table[:, 1:].reshape(1, side, side, -1).permute(0, 3, 1, 2)
        offset = self.sizes.interpolate_offset
        if offset:
            resize = {"scale_factor": ((rows + offset) / side, (columns + offset) / side)}
        else:
            resize = {"size": (rows, columns)}
        grid = F.interpolate(grid, mode="bicubic", antialias=self.sizes.interpolate_antialias, **resize)
        grid = grid.permute(0, 2, 3, 1).reshape(1, rows * columns, -1)
        return torch.cat((table[:, :1], grid), dim=1).to(self.pos_embed.dtype)

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        """(B, in_chans, H, W) normalized images -> (B, patches, dim) normalized patch tokens."""
        batch, _, height, width = images.shape
        tokens = self.patch_embed(images)
        tokens = torch.cat((self.cls_token.expand(batch, -1, -1), tokens), dim=1)
        tokens = tokens + self.position_embedding(height // self.patch_size, width // self.patch_size)
        registers = self.register_tokens.expand(batch, -1, -1)
        tokens = torch.cat((tokens[:, :1], registers, tokens[:, 1:]), dim=1)
        for block in self.blocks:
            tokens = block(tokens)
        return self.norm(tokens)[:, 1 + self.num_register_tokens :]
