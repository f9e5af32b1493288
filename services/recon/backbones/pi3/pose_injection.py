"""Pi3X's pose injection: attention across views whose positional encoding is the cameras themselves.

Each head's channels are split into a half transformed by the token's camera (camera-from-world
4x4 matrices on groups of 4 channels: the query by P^T, keys and values by P^-1, the output by P,
so attention scores depend only on relative poses) and two quarters rotated by the patch's column
and row (rotary, 0-based, per view). This is the projective positional encoding without
intrinsics; the block's output (attention plus MLP, no residual) is added only to views that have
a pose.
"""

from __future__ import annotations

import torch

from services.recon.backbones.transformer.layers import Attention, Block, attend

ROPE_BASE = 100.0


def invert_rigid(transforms: torch.Tensor) -> torch.Tensor:
    """Inverse of (..., 4, 4) rigid transforms [R|t; 0 1]."""
    rotation_t = transforms[..., :3, :3].transpose(-1, -2)
    out = torch.zeros_like(transforms)
    out[..., :3, :3] = rotation_t
    out[..., :3, 3] = -(rotation_t @ transforms[..., :3, 3:4])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def _per_camera(features: torch.Tensor, matrices: torch.Tensor) -> torch.Tensor:
    """Multiply each group of 4 channels of every token by its camera's 4x4 matrix.

    features (B, heads, N * tokens, C) with C a multiple of 4; matrices (B, N, 4, 4).
    """
    batch, heads, length, channels = features.shape
    views = matrices.shape[1]
    grouped = features.reshape(batch, heads, views, length // views, channels // 4, 4)
    return torch.einsum("bvij,bhvtgj->bhvtgi", matrices, grouped).reshape(features.shape)


def _rotary(features: torch.Tensor, positions: torch.Tensor, inverse: bool = False) -> torch.Tensor:
    """Rotate channel pairs (j, j + C/2) of (..., tokens, C) by position * base^(-j / (C/2)).

    The rotation's sense is the opposite of `RotaryEmbedding2D`'s (as published); `inverse` undoes it.
    """
    half = features.shape[-1] // 2
    frequencies = ROPE_BASE ** (-torch.arange(half, device=features.device, dtype=torch.float32) / half)
    angles = (positions.to(torch.float32)[:, None] * frequencies).to(features.dtype)
    cos, sin = angles.cos(), angles.sin()
    first, second = features[..., :half], features[..., half:]
    if inverse:
        return torch.cat((cos * first - sin * second, sin * first + cos * second), dim=-1)
    return torch.cat((cos * first + sin * second, -sin * first + cos * second), dim=-1)


class ProjectiveAttention(Attention):
    """Self-attention over all views' patch tokens with camera-relative positional encoding."""

    def encode(
        self,
        x: torch.Tensor,
        matrices: torch.Tensor,
        rows: torch.Tensor,
        columns: torch.Tensor,
        inverse: bool,
    ) -> torch.Tensor:
        quarter = x.shape[-1] // 4
        return torch.cat(
            (
                _per_camera(x[..., : 2 * quarter], matrices),
                _rotary(x[..., 2 * quarter : 3 * quarter], columns, inverse),
                _rotary(x[..., 3 * quarter :], rows, inverse),
            ),
            dim=-1,
        )

    def forward(  # type: ignore[override]
        self, x: torch.Tensor, viewmats: torch.Tensor, grid: tuple[int, int], mask: torch.Tensor | None = None
    ) -> torch.Tensor:
        """x (B, N * rows * cols, C) patch tokens, view-major; viewmats (B, N, 4, 4) camera-from-world."""
        rows, columns = grid
        views = viewmats.shape[1]
        row_index = torch.arange(rows, device=x.device).repeat_interleave(columns).repeat(views)
        column_index = torch.arange(columns, device=x.device).repeat(rows * views)
        query, key, value = self.heads(x)
        inverse_views = invert_rigid(viewmats)
        query = self.encode(query, viewmats.transpose(-1, -2), row_index, column_index, False)
        key = self.encode(key, inverse_views, row_index, column_index, False)
        value = self.encode(value, inverse_views, row_index, column_index, False)
        out = self.encode(attend(query, key, value, mask), viewmats, row_index, column_index, True)
        return self.merge(out)


class PoseInjectBlock(Block):
    """Attention and MLP side by side on the same normalized input; returns their sum (no residual)."""

    def __init__(self, dim: int, num_heads: int, mlp_ratio: float, init_values: float) -> None:
        super().__init__(
            dim,
            num_heads,
            mlp_ratio,
            init_values,
            norm_eps=1e-6,
            attention=ProjectiveAttention(dim, num_heads, qk_norm=True),
        )

    def forward(  # type: ignore[override]
        self, x: torch.Tensor, poses: torch.Tensor, grid: tuple[int, int], mask: torch.Tensor | None = None
    ) -> torch.Tensor:
        """x (B, N * patches, C); poses (B, N, 4, 4) camera-to-world (already normalized)."""
        attended = self.attn(self.norm1(x), invert_rigid(poses), grid, mask)
        return self.ls1(attended) + self.ls2(self.mlp(self.norm2(x)))


def view_pair_mask(pose_mask: torch.Tensor, patches: int) -> torch.Tensor | None:
    """(B, N) bool -> (B, 1, N * patches, N * patches) mask: tokens attend only between views that
    both have a pose; None when every view has one (no mask needed)."""
    if bool(pose_mask.all()):
        return None
    pairs = pose_mask[:, :, None] & pose_mask[:, None, :]
    return pairs.repeat_interleave(patches, dim=1).repeat_interleave(patches, dim=2)[:, None]
