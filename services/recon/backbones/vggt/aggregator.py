"""The alternating-attention trunk: frame-wise and global self-attention over all views' tokens."""

from __future__ import annotations

import torch
from torch import nn

from services.recon.backbones.transformer.dinov2 import DinoV2WithRegisters
from services.recon.backbones.transformer.layers import Block, RotaryEmbedding2D, token_positions
from services.recon.backbones.vggt.config import VGGTConfig

# ImageNet statistics the DINOv2 embedder was trained with.
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


def first_and_other_frames(token: torch.Tensor, batch: int, frames: int) -> torch.Tensor:
    """(1, 2, n, C) learned tokens -> (batch * frames, n, C): entry 0 for frame 0, entry 1 for the rest."""
    first = token[:, :1].expand(batch, 1, *token.shape[2:])
    others = token[:, 1:].expand(batch, frames - 1, *token.shape[2:])
    return torch.cat((first, others), dim=1).reshape(batch * frames, *token.shape[2:])


class Aggregator(nn.Module):
    def __init__(self, config: VGGTConfig) -> None:
        super().__init__()
        dim = config.embed_dim
        self.patch_size = config.patch_size
        self.patch_embed = DinoV2WithRegisters(
            config.patch_embed, config.img_size, config.patch_size, config.num_register_tokens
        )
        self.rope = RotaryEmbedding2D(config.rope_freq) if config.rope_freq > 0 else None

        def make_block() -> Block:
            return Block(
                dim, config.num_heads, config.mlp_ratio, config.init_values, config.qk_norm, rope=self.rope
            )

        self.frame_blocks = nn.ModuleList(make_block() for _ in range(config.depth))
        self.global_blocks = nn.ModuleList(make_block() for _ in range(config.depth))
        # Index 0 along dim 1 serves the first (reference) frame, index 1 every other frame.
        self.camera_token = nn.Parameter(torch.randn(1, 2, 1, dim) * 1e-6)
        self.register_token = nn.Parameter(torch.randn(1, 2, config.num_register_tokens, dim) * 1e-6)
        self.patch_start_idx = 1 + config.num_register_tokens

    def forward(self, images: torch.Tensor, keep: set[int] | None = None) -> list[torch.Tensor | None]:
        """(B, S, 3, H, W) images in [0, 1] -> per block pair, (B, S, tokens, 2 * dim).

        Each output concatenates the frame block's and the global block's result; tokens are the
        camera token, the register tokens, then the patches in raster order. Outputs of block
        pairs not in `keep` (when given) are None, which saves memory with many views.
        """
        batch, frames, channels, height, width = images.shape
        mean = torch.tensor(IMAGENET_MEAN, device=images.device, dtype=images.dtype).view(1, 1, 3, 1, 1)
        std = torch.tensor(IMAGENET_STD, device=images.device, dtype=images.dtype).view(1, 1, 3, 1, 1)
        normalized = ((images - mean) / std).reshape(batch * frames, channels, height, width)
        patches = self.patch_embed(normalized)
        tokens = torch.cat(
            (
                first_and_other_frames(self.camera_token, batch, frames),
                first_and_other_frames(self.register_token, batch, frames),
                patches,
            ),
            dim=1,
        )
        count, dim = tokens.shape[1], tokens.shape[2]

        # Patches sit at (row + 1, column + 1); camera and register tokens at (0, 0).
        positions = token_positions(
            batch * frames,
            self.patch_start_idx,
            height // self.patch_size,
            width // self.patch_size,
            images.device,
        )

        outputs: list[torch.Tensor | None] = []
        for index, (frame_block, global_block) in enumerate(
            zip(self.frame_blocks, self.global_blocks, strict=True)
        ):
            tokens = frame_block(tokens.reshape(batch * frames, count, dim), positions)
            frame_out = tokens.reshape(batch, frames, count, dim)
            tokens = global_block(
                tokens.reshape(batch, frames * count, dim), positions.reshape(batch, frames * count, 2)
            )
            global_out = tokens.reshape(batch, frames, count, dim)
            wanted = keep is None or index in keep
            outputs.append(torch.cat((frame_out, global_out), dim=-1) if wanted else None)
        return outputs
