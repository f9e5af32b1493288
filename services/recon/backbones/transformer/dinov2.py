"""DINOv2 vision transformer with register tokens: VGGT's patch embedder, Pi3's image (and depth) encoder."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from services.recon.backbones.transformer.layers import Block
from services.recon.backbones.transformer.sizes import DinoV2Config


class PatchProjection(nn.Module):
    """Non-overlapping patch_size x patch_size convolution: image -> (B, patches, dim)."""

    def __init__(self, patch_size: int, embed_dim: int, in_chans: int = 3) -> None:
        super().__init__()
        self.proj = nn.Conv2d(in_chans, embed_dim, kernel_size=patch_size, stride=patch_size)

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        return self.proj(images).flatten(2).transpose(1, 2)


class DinoV2WithRegisters(nn.Module):
    """`in_chans`: 3 for images, 2 for Pi3X's depth encoder (depth, validity). `mask_token`: VGGT's
    checkpoint keeps DINOv2's training-only mask token, Pi3's do not."""

    def __init__(
        self,
        config: DinoV2Config,
        img_size: int,
        patch_size: int,
        num_register_tokens: int,
        in_chans: int = 3,
        mask_token: bool = True,
    ) -> None:
        super().__init__()
        dim = config.embed_dim
        self.config = config
        self.patch_size = patch_size
        self.grid_side = img_size // patch_size  # the position table covers this square grid
        self.patch_embed = PatchProjection(patch_size, dim, in_chans)
        self.cls_token = nn.Parameter(torch.zeros(1, 1, dim))
        self.pos_embed = nn.Parameter(torch.zeros(1, self.grid_side**2 + 1, dim))
        self.register_tokens = nn.Parameter(torch.zeros(1, num_register_tokens, dim))
        if mask_token:
            # Used by DINOv2 only for masked-image training; kept so the checkpoint loads unchanged.
            self.mask_token = nn.Parameter(torch.zeros(1, dim), requires_grad=False)
        self.blocks = nn.ModuleList(
            Block(dim, config.num_heads, config.mlp_ratio, config.init_values, norm_eps=1e-6)
            for _ in range(config.depth)
        )
        self.norm = nn.LayerNorm(dim, eps=1e-6)
        self.num_register_tokens = num_register_tokens

    def position_embedding(self, rows: int, columns: int) -> torch.Tensor:
        """The class token's embedding and the patch grid's, resampled to rows x columns (bicubic)."""
        side = self.grid_side
        if rows == side and columns == side:
            return self.pos_embed
        table = self.pos_embed.float()
        grid = table[:, 1:].reshape(1, side, side, -1).permute(0, 3, 1, 2)
        offset = self.config.interpolate_offset
        if offset:
            resize = {"scale_factor": ((rows + offset) / side, (columns + offset) / side)}
        else:
            resize = {"size": (rows, columns)}
        grid = F.interpolate(grid, mode="bicubic", antialias=self.config.interpolate_antialias, **resize)
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
