"""Transformer building blocks shared by VGGT and Pi3 (their encoders, trunks and heads).

Module attribute names (norm1, attn.qkv, ls1.gamma, mlp.fc1, ...) are the checkpoints' tensor names,
so both models' published state dicts load with no renaming.
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


def layer_scale(dim: int, init_values: float | None) -> nn.Module:
    """A LayerScale, or nothing (no tensors) when the architecture has none (init_values None)."""
    return LayerScale(dim, init_values) if init_values is not None else nn.Identity()


class Mlp(nn.Module):
    def __init__(self, in_features: int, hidden_features: int, out_features: int | None = None) -> None:
        super().__init__()
        self.fc1 = nn.Linear(in_features, hidden_features)
        self.act = nn.GELU()
        self.fc2 = nn.Linear(hidden_features, out_features or in_features)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.fc2(self.act(self.fc1(x)))


class RotaryEmbedding2D(nn.Module):
    """Rotary position embedding over (row, column) token coordinates.

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


def attend(
    query: torch.Tensor, key: torch.Tensor, value: torch.Tensor, mask: torch.Tensor | None = None
) -> torch.Tensor:
    """Scaled dot-product attention; with a boolean mask (True = may attend), a query that may
    attend to nothing gets zeros, never NaN (whatever kernel the device picks)."""
    out = F.scaled_dot_product_attention(query, key, value, attn_mask=mask)
    if mask is not None:
        out = out.masked_fill(~mask.any(dim=-1, keepdim=True), 0.0)
    return out


class Attention(nn.Module):
    """Multi-head self-attention with optional QK-norm and 2D rotary positions."""

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

    def heads(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(B, N, C) -> query, key, value (B, heads, N, head_dim), QK-norm applied."""
        batch, tokens, _ = x.shape
        qkv = self.qkv(x).reshape(batch, tokens, 3, self.num_heads, self.head_dim).permute(2, 0, 3, 1, 4)
        query, key, value = qkv.unbind(0)
        return self.q_norm(query), self.k_norm(key), value

    def merge(self, x: torch.Tensor) -> torch.Tensor:
        """(B, heads, N, head_dim) attention output -> (B, N, C) projected."""
        batch, _, tokens, _ = x.shape
        return self.proj(x.transpose(1, 2).reshape(batch, tokens, self.num_heads * self.head_dim))

    def forward(self, x: torch.Tensor, positions: torch.Tensor | None = None) -> torch.Tensor:
        query, key, value = self.heads(x)
        if self.rope is not None and positions is not None:
            query, key = self.rope(query, positions), self.rope(key, positions)
        return self.merge(attend(query, key, value))


class Block(nn.Module):
    """Pre-norm transformer block, with layer scale on both residual branches unless init_values is None."""

    def __init__(
        self,
        dim: int,
        num_heads: int,
        mlp_ratio: float = 4.0,
        init_values: float | None = 0.01,
        qk_norm: bool = False,
        rope: RotaryEmbedding2D | None = None,
        norm_eps: float = 1e-5,
        attention: Attention | None = None,
    ) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(dim, eps=norm_eps)
        self.attn = attention or Attention(dim, num_heads, qk_norm=qk_norm, rope=rope)
        self.ls1 = layer_scale(dim, init_values)
        self.norm2 = nn.LayerNorm(dim, eps=norm_eps)
        self.mlp = Mlp(dim, int(dim * mlp_ratio))
        self.ls2 = layer_scale(dim, init_values)

    def forward(self, x: torch.Tensor, positions: torch.Tensor | None = None) -> torch.Tensor:
        x = x + self.ls1(self.attn(self.norm1(x), positions))
        return x + self.ls2(self.mlp(self.norm2(x)))


def patch_grid_positions(batch: int, rows: int, columns: int, device: torch.device) -> torch.Tensor:
    """(batch, rows * columns, 2) integer (row, column) of each patch in raster order."""
    row_index = torch.arange(rows, device=device).repeat_interleave(columns)
    column_index = torch.arange(columns, device=device).repeat(rows)
    return torch.stack((row_index, column_index), dim=-1)[None].expand(batch, -1, -1)


def token_positions(batch: int, special: int, rows: int, columns: int, device: torch.device) -> torch.Tensor:
    """(batch, special + rows * columns, 2) rotary positions: (0, 0) for the special tokens in front
    (camera, registers), (row + 1, column + 1) for the patches, so no patch shares the specials' place."""
    grid = patch_grid_positions(batch, rows, columns, device)
    front = torch.zeros(batch, special, 2, dtype=grid.dtype, device=device)
    return torch.cat((front, grid + 1), dim=1)


def uv_grid(width: int, height: int, aspect_ratio: float, dtype: torch.dtype, device: torch.device):
    """(height, width, 2) normalized (u, v) coordinates of cell centres; the grid's diagonal is 1.

    Dense heads (VGGT's DPT, Pi3X's conv heads) feed it to their convolutions so that they know
    the image's aspect ratio at every resolution.
    """
    diagonal = (aspect_ratio**2 + 1.0) ** 0.5
    span_x, span_y = aspect_ratio / diagonal, 1.0 / diagonal
    reach_x = span_x * (width - 1) / width
    reach_y = span_y * (height - 1) / height
    u = torch.linspace(-reach_x, reach_x, steps=width, dtype=dtype, device=device)
    v = torch.linspace(-reach_y, reach_y, steps=height, dtype=dtype, device=device)
    vv, uu = torch.meshgrid(v, u, indexing="ij")
    return torch.stack((uu, vv), dim=-1)
