"""Pi3X's metric-scale decoder: one learned token cross-attends to every token of every view; a
linear head turns the result into the log of the factor that makes the reconstruction metric."""

from __future__ import annotations

import torch
from torch import nn

from services.recon.backbones.transformer.layers import Mlp, RotaryEmbedding2D, attend
from services.recon.backbones.transformer.sizes import TransformerSizes


class CrossAttention(nn.Module):
    def __init__(self, dim: int, num_heads: int, rope: RotaryEmbedding2D) -> None:
        super().__init__()
        self.num_heads = num_heads
        self.q_proj = nn.Linear(dim, dim)
        self.k_proj = nn.Linear(dim, dim)
        self.v_proj = nn.Linear(dim, dim)
        self.proj = nn.Linear(dim, dim)
        self.rope = rope

    def _heads(self, x: torch.Tensor) -> torch.Tensor:
        batch, tokens, channels = x.shape
        return x.reshape(batch, tokens, self.num_heads, channels // self.num_heads).transpose(1, 2)

    def forward(
        self,
        x: torch.Tensor,
        context: torch.Tensor,
        x_positions: torch.Tensor,
        context_positions: torch.Tensor,
    ) -> torch.Tensor:
        query = self.rope(self._heads(self.q_proj(x)), x_positions)
        key = self.rope(self._heads(self.k_proj(context)), context_positions)
        out = attend(query, key, self._heads(self.v_proj(context)))
        return self.proj(out.transpose(1, 2).reshape(x.shape))


class CrossOnlyBlock(nn.Module):
    """Pre-norm cross-attention (queries from x, keys and values from the context) and an MLP."""

    def __init__(self, dim: int, num_heads: int, mlp_ratio: float, rope: RotaryEmbedding2D) -> None:
        super().__init__()
        self.norm2 = nn.LayerNorm(dim, eps=1e-6)
        self.norm_y = nn.LayerNorm(dim, eps=1e-6)
        self.cross_attn = CrossAttention(dim, num_heads, rope)
        self.norm3 = nn.LayerNorm(dim, eps=1e-6)
        self.mlp = Mlp(dim, int(dim * mlp_ratio))

    def forward(self, x: torch.Tensor, context: torch.Tensor, x_pos: torch.Tensor, context_pos: torch.Tensor):
        x = x + self.cross_attn(self.norm2(x), self.norm_y(context), x_pos, context_pos)
        return x + self.mlp(self.norm3(x))


class MetricDecoder(nn.Module):
    def __init__(self, in_dim: int, sizes: TransformerSizes, out_dim: int, rope: RotaryEmbedding2D) -> None:
        super().__init__()
        dim = sizes.embed_dim
        self.projects_x = nn.Linear(in_dim, dim)
        self.projects_y = nn.Linear(in_dim, dim)
        self.blocks = nn.ModuleList(
            CrossOnlyBlock(dim, sizes.num_heads, sizes.mlp_ratio, rope) for _ in range(sizes.depth)
        )
        self.linear_out = nn.Linear(dim, out_dim)

    def forward(
        self, query: torch.Tensor, context: torch.Tensor, query_pos: torch.Tensor, context_pos: torch.Tensor
    ) -> torch.Tensor:
        """query (B, 1, in_dim), context (B, N * tokens, in_dim) with their positions -> (B, 1, out_dim)."""
        x, context = self.projects_x(query), self.projects_y(context)
        for block in self.blocks:
            x = block(x, context, query_pos, context_pos)
        return self.linear_out(x)
