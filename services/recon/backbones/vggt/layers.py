"""Transformer building blocks shared by the patch embedder, the aggregator and the camera head.

Module attribute names (norm1, attn.qkv, ls1.gamma, mlp.fc1, ...) are the checkpoint's tensor names.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn


class LayerScale(nn.Module):
    """Per-channel learned scaling of a residual branch."""

    def __init__(self, dim: int, init_values: float) -> None:
        super().__init__()
        self.gamma = nn.Parameter(torch.full((dim,), float(init_values)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x * self.gamma


class Mlp(nn.Module):
    def __init__(self, in_features: int, hidden_features: int, out_features: int | None = None) -> None:
        super().__init__()
        self.fc1 = nn.Linear(in_features, hidden_features)
        self.act = nn.GELU()
        self.fc2 = nn.Linear(hidden_features, out_features or in_features)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.fc2(self.act(self.fc1(x)))


class RotaryEmbedding2D(nn.Module):
    """Rotary position embedding over (row, column) patch coordinates.

    The first half of each head's channels is rotated by the row index, the second half by the
    column index; within a half, channel j and j + d/2 form a rotating pair with frequency
    base^(-2j/d).
    """

    def __init__(self, base_frequency: float = 100.0) -> None:
        super().__init__()
        self.base_frequency = base_frequency

    def _rotate_1d(self, x: torch.Tensor, positions: torch.Tensor) -> torch.Tensor:
        half = x.shape[-1] // 2
        exponents = torch.arange(0, x.shape[-1], 2, device=x.device, dtype=torch.float32) / x.shape[-1]
        inverse_frequency = 1.0 / (self.base_frequency**exponents)
        angles = positions.to(torch.float32)[..., None] * inverse_frequency  # (B, N, half)
        angles = torch.cat((angles, angles), dim=-1)[:, None].to(x.dtype)  # (B, 1, N, 2 * half)
        rotated = torch.cat((-x[..., half:], x[..., :half]), dim=-1)
        return x * angles.cos() + rotated * angles.sin()

    def forward(self, x: torch.Tensor, positions: torch.Tensor) -> torch.Tensor:
        """x: (B, heads, N, head_dim); positions: (B, N, 2) integer (row, column)."""
        rows, columns = x.chunk(2, dim=-1)
        return torch.cat(
            (self._rotate_1d(rows, positions[..., 0]), self._rotate_1d(columns, positions[..., 1])), dim=-1
        )


class Attention(nn.Module):
    def __init__(
        self, dim: int, num_heads: int, qk_norm: bool = False, rope: RotaryEmbedding2D | None = None
    ) -> None:
        super().__init__()
        self.num_heads = num_heads
        self.head_dim = dim // num_heads
        self.qkv = nn.Linear(dim, dim * 3)
        # QK-norm: LayerNorm over each head's channels, which keeps attention logits bounded.
        self.q_norm: nn.Module = nn.LayerNorm(self.head_dim) if qk_norm else nn.Identity()
        self.k_norm: nn.Module = nn.LayerNorm(self.head_dim) if qk_norm else nn.Identity()
        self.proj = nn.Linear(dim, dim)
        self.rope = rope

    def forward(self, x: torch.Tensor, positions: torch.Tensor | None = None) -> torch.Tensor:
        batch, tokens, channels = x.shape
        qkv = self.qkv(x).reshape(batch, tokens, 3, self.num_heads, self.head_dim).permute(2, 0, 3, 1, 4)
        query, key, value = qkv.unbind(0)
        query, key = self.q_norm(query), self.k_norm(key)
        if self.rope is not None and positions is not None:
            query, key = self.rope(query, positions), self.rope(key, positions)
        x = F.scaled_dot_product_attention(query, key, value)
        return self.proj(x.transpose(1, 2).reshape(batch, tokens, channels))


class Block(nn.Module):
    """Pre-norm transformer block with layer scale on both residual branches."""

    def __init__(
        self,
        dim: int,
        num_heads: int,
        mlp_ratio: float = 4.0,
        init_values: float = 0.01,
        qk_norm: bool = False,
        rope: RotaryEmbedding2D | None = None,
        norm_eps: float = 1e-5,
    ) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(dim, eps=norm_eps)
        self.attn = Attention(dim, num_heads, qk_norm=qk_norm, rope=rope)
        self.ls1 = LayerScale(dim, init_values)
        self.norm2 = nn.LayerNorm(dim, eps=norm_eps)
        self.mlp = Mlp(dim, int(dim * mlp_ratio))
        self.ls2 = LayerScale(dim, init_values)

    def forward(self, x: torch.Tensor, positions: torch.Tensor | None = None) -> torch.Tensor:
        x = x + self.ls1(self.attn(self.norm1(x), positions))
        return x + self.ls2(self.mlp(self.norm2(x)))


def patch_grid_positions(batch: int, rows: int, columns: int, device: torch.device) -> torch.Tensor:
    """(batch, rows * columns, 2) integer (row, column) of each patch in raster order."""
    row_index = torch.arange(rows, device=device).repeat_interleave(columns)
    column_index = torch.arange(columns, device=device).repeat(rows)
    return torch.stack((row_index, column_index), dim=-1)[None].expand(batch, -1, -1)
