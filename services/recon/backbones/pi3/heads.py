"""Pi3's heads: a small transformer per output, a linear patch head for points and confidence
(Pi3), and the camera head that turns each view's patch features into a 4x4 camera-to-world pose.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from services.recon.backbones.transformer.layers import Block, RotaryEmbedding2D


class HeadDecoder(nn.Module):
    """Projects the trunk's features, runs per-view transformer blocks (no layer scale), projects out."""

    def __init__(
        self,
        in_dim: int,
        embed_dim: int,
        depth: int,
        num_heads: int,
        mlp_ratio: float,
        out_dim: int,
        rope: RotaryEmbedding2D,
    ) -> None:
        super().__init__()
        self.projects = nn.Linear(in_dim, embed_dim)
        self.blocks = nn.ModuleList(
            Block(embed_dim, num_heads, mlp_ratio, init_values=None, rope=rope, norm_eps=1e-6)
            for _ in range(depth)
        )
        self.linear_out = nn.Linear(embed_dim, out_dim)

    def forward(self, tokens: torch.Tensor, positions: torch.Tensor) -> torch.Tensor:
        """(B*N, tokens, in_dim) with (B*N, tokens, 2) positions -> (B*N, tokens, out_dim)."""
        hidden = self.projects(tokens)
        for block in self.blocks:
            hidden = block(hidden, positions)
        return self.linear_out(hidden)


class PatchLinearHead(nn.Module):
    """Each patch token predicts its patch_size x patch_size pixels' values (a pixel shuffle)."""

    def __init__(self, in_dim: int, patch_size: int, channels: int) -> None:
        super().__init__()
        self.patch_size = patch_size
        self.proj = nn.Linear(in_dim, channels * patch_size**2)

    def forward(self, patches: torch.Tensor, rows: int, columns: int) -> torch.Tensor:
        """(B*N, rows * columns, in_dim) -> (B*N, H, W, channels)."""
        features = self.proj(patches).transpose(1, 2).reshape(patches.shape[0], -1, rows, columns)
        return F.pixel_shuffle(features, self.patch_size).permute(0, 2, 3, 1)


class ResidualLinear(nn.Module):
    """Three ReLU-activated linear layers added to their input."""

    def __init__(self, dim: int) -> None:
        super().__init__()
        self.res_conv1 = nn.Linear(dim, dim)
        self.res_conv2 = nn.Linear(dim, dim)
        self.res_conv3 = nn.Linear(dim, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        update = F.relu(self.res_conv3(F.relu(self.res_conv2(F.relu(self.res_conv1(x))))))
        return x + update


def rotation_from_9d(values: torch.Tensor) -> torch.Tensor:
    """(..., 9) -> (..., 3, 3) the rotation (det +1) nearest to the 3x3 matrix with unit rows.

    The rows are normalized first; the nearest rotation comes from the SVD, with the reflection
    (det -1) case flipped to a proper rotation.
    """
    matrix = F.normalize(values.reshape(*values.shape[:-1], 3, 3), dim=-1)
    u, _, vh = torch.linalg.svd(matrix.transpose(-1, -2))
    v = vh.transpose(-1, -2)
    sign = torch.det(v @ u.transpose(-1, -2))
    v = torch.cat((v[..., :-1], v[..., -1:] * sign[..., None, None]), dim=-1)
    return v @ u.transpose(-1, -2)


class CameraHead(nn.Module):
    """Per view: residual MLPs over patch features, average over patches, then translation and rotation."""

    def __init__(self, dim: int) -> None:
        super().__init__()
        self.res_conv = nn.ModuleList(ResidualLinear(dim) for _ in range(2))
        self.more_mlps = nn.Sequential(nn.Linear(dim, dim), nn.ReLU(), nn.Linear(dim, dim), nn.ReLU())
        self.fc_t = nn.Linear(dim, 3)
        self.fc_rot = nn.Linear(dim, 9)

    def forward(self, patches: torch.Tensor) -> torch.Tensor:
        """(B*N, patches, dim) -> (B*N, 4, 4) camera-to-world poses (OpenCV axes)."""
        features = patches
        for block in self.res_conv:
            features = block(features)
        pooled = self.more_mlps(features.mean(dim=1)).float()
        pose = torch.zeros(patches.shape[0], 4, 4, dtype=pooled.dtype, device=pooled.device)
        pose[:, :3, :3] = rotation_from_9d(self.fc_rot(pooled))
        pose[:, :3, 3] = self.fc_t(pooled)
        pose[:, 3, 3] = 1.0
        return pose
