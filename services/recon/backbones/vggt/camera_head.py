"""Camera head: iteratively refines a 9-number pose encoding per view from its camera token.

Encoding: translation (3), rotation quaternion scalar-last xyzw (4), field of view h then w
(2, radians). Decode it with `geometry.pose_encoding_to_cameras`.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from services.recon.backbones.transformer.layers import Block, Mlp
from services.recon.backbones.vggt.config import CameraHeadConfig

POSE_ENCODING_SIZE = 9


def activate_pose(encoding: torch.Tensor) -> torch.Tensor:
    """Translation and quaternion pass through; the fields of view are kept non-negative."""
    return torch.cat((encoding[..., :7], F.relu(encoding[..., 7:])), dim=-1)


class CameraHead(nn.Module):
    def __init__(self, config: CameraHeadConfig) -> None:
        super().__init__()
        dim = config.dim_in
        self.num_iterations = config.num_iterations
        self.trunk = nn.Sequential(
            *(
                Block(dim, config.num_heads, config.mlp_ratio, config.init_values)
                for _ in range(config.trunk_depth)
            )
        )
        self.token_norm = nn.LayerNorm(dim)
        self.trunk_norm = nn.LayerNorm(dim)
        # The "previous estimate" fed to the first iteration.
        self.empty_pose_tokens = nn.Parameter(torch.zeros(1, 1, POSE_ENCODING_SIZE))
        self.embed_pose = nn.Linear(POSE_ENCODING_SIZE, dim)
        # Adaptive layer norm: the current estimate predicts shift, scale and gate of the tokens.
        self.poseLN_modulation = nn.Sequential(nn.SiLU(), nn.Linear(dim, 3 * dim))
        self.adaln_norm = nn.LayerNorm(dim, elementwise_affine=False, eps=1e-6)
        self.pose_branch = Mlp(dim, dim // 2, POSE_ENCODING_SIZE)

    def forward(self, last_tokens: torch.Tensor) -> list[torch.Tensor]:
        """(B, S, tokens, dim) last aggregator output -> one (B, S, 9) encoding per iteration."""
        camera_tokens = self.token_norm(last_tokens[:, :, 0])
        batch, frames, _ = camera_tokens.shape
        estimate: torch.Tensor | None = None
        estimates = []
        for _ in range(self.num_iterations):
            previous = self.empty_pose_tokens.expand(batch, frames, -1) if estimate is None else estimate
            shift, scale, gate = self.poseLN_modulation(self.embed_pose(previous)).chunk(3, dim=-1)
            modulated = gate * (self.adaln_norm(camera_tokens) * (1 + scale) + shift) + camera_tokens
            # The trunk attends across the views of each scene.
            delta = self.pose_branch(self.trunk_norm(self.trunk(modulated)))
            estimate = delta if estimate is None else estimate + delta
            estimates.append(activate_pose(estimate))
        return estimates
