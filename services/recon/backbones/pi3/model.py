"""Pi3 and Pi3X: images of one scene -> per-view camera poses, local and world point maps, confidence.

Both are permutation-equivariant: no view is the reference; the world frame is not tied to any
input view. A DINOv2-L/14-with-registers encoder turns each view into patch tokens; a trunk of
blocks that alternate attention within each view and across all views (2D RoPE) mixes them; small
transformers feed a point head, a confidence head and a camera head. Pi3X has convolutional
point and confidence heads, a metric-scale head, and can be conditioned on intrinsics (as rays),
poses and depths, per view. Submodule names are the published checkpoints' tensor names.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import torch
import torch.nn.functional as F
from torch import nn

from services.recon.backbones.pi3.conditioning import Conditions, prepare_conditions
from services.recon.backbones.pi3.config import IMAGENET_MEAN, IMAGENET_STD, Pi3Config
from services.recon.backbones.pi3.conv_head import ConvHead
from services.recon.backbones.pi3.heads import CameraHead, HeadDecoder, PatchLinearHead
from services.recon.backbones.pi3.metric import MetricDecoder
from services.recon.backbones.pi3.pose_injection import PoseInjectBlock, view_pair_mask
from services.recon.backbones.transformer.dinov2 import DinoV2WithRegisters
from services.recon.backbones.transformer.dinov2 import PatchProjection as RayEmbedding
from services.recon.backbones.transformer.layers import Block, RotaryEmbedding2D, token_positions

MAX_LOG_DEPTH = 15.0  # Pi3X clamps the predicted log-depth before exp
AfterBlock = Callable[[int, torch.Tensor], torch.Tensor]


def transform_points(poses: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
    """(B, N, 4, 4) camera-to-world, (B, N, H, W, 3) camera-frame points -> world points."""
    rotated = torch.einsum("bnij,bnhwj->bnhwi", poses[..., :3, :3], points)
    return rotated + poses[:, :, None, None, :3, 3]


class Pi3Trunk(nn.Module):
    """What Pi3 and Pi3X share: encoder, alternating decoder, head transformers, camera head."""

    def __init__(self, config: Pi3Config) -> None:
        super().__init__()
        self.config = config
        dim, patch = config.decoder_dim, config.patch_size
        self.patch_size = patch
        self.patch_start_idx = config.num_register_tokens
        self.rope = RotaryEmbedding2D(config.rope_freq)
        self.encoder = self._encoder(in_chans=3)
        self.decoder = nn.ModuleList(
            Block(
                dim,
                config.decoder.num_heads,
                config.decoder.mlp_ratio,
                config.decoder_init_values,
                qk_norm=True,
                rope=self.rope,
                norm_eps=1e-6,
            )
            for _ in range(config.decoder.depth)
        )
        self.register_token = nn.Parameter(torch.zeros(1, 1, config.num_register_tokens, dim))
        self.register_buffer("image_mean", torch.tensor(IMAGENET_MEAN).view(1, 3, 1, 1))
        self.register_buffer("image_std", torch.tensor(IMAGENET_STD).view(1, 3, 1, 1))
        self.point_decoder = self._head_decoder(config.point_decoder_out_dim)
        self.conf_decoder = self._head_decoder(config.conf_decoder_out_dim)
        self.camera_decoder = self._head_decoder(config.camera_decoder_out_dim)
        self.camera_head = CameraHead(config.camera_decoder_out_dim)

    def _encoder(self, in_chans: int) -> DinoV2WithRegisters:
        config = self.config
        return DinoV2WithRegisters(
            config.encoder,
            config.encoder_img_size,
            config.patch_size,
            config.encoder_registers,
            in_chans,
            False,
        )

    def _head_decoder(self, out_dim: int) -> HeadDecoder:
        head = self.config.head_decoder
        return HeadDecoder(
            2 * self.config.decoder_dim,
            head.embed_dim,
            head.depth,
            head.num_heads,
            head.mlp_ratio,
            out_dim,
            self.rope,
        )

    def grid(self, images: torch.Tensor) -> tuple[int, int]:
        """Patch rows and columns of (B, N, 3, H, W) images; H and W must be multiples of the patch."""
        if images.ndim != 5 or images.shape[2] != 3:
            raise ValueError(f"images must be (B, N, 3, H, W), not {tuple(images.shape)}")
        height, width = images.shape[-2:]
        if height % self.patch_size or width % self.patch_size:
            raise ValueError(
                f"image size {width}x{height} is not a multiple of the patch size {self.patch_size}"
            )
        return height // self.patch_size, width // self.patch_size

    def encode_images(self, images: torch.Tensor) -> torch.Tensor:
        """(B, N, 3, H, W) RGB in [0, 1] -> (B*N, patches, dim) encoder patch tokens."""
        normalized = (images - self.image_mean) / self.image_std
        return self.encoder(normalized.reshape(-1, *images.shape[2:]))

    def decode(
        self, tokens: torch.Tensor, views: int, grid: tuple[int, int], after_block: AfterBlock | None = None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """(B*N, patches, dim) -> features (B*N, tokens, 2 * dim) and rotary positions (B*N, tokens, 2).

        Register tokens go in front of each view's patches. Even blocks attend within each view,
        odd ones across all views; `after_block(i, (B, N, tokens, dim))` may change the tokens after
        block i. Features are the outputs of the last two blocks, side by side.
        """
        frames, _, dim = tokens.shape
        batch = frames // views
        registers = self.register_token.expand(batch, views, -1, -1).reshape(frames, -1, dim)
        hidden = torch.cat((registers, tokens), dim=1)
        count = hidden.shape[1]
        positions = token_positions(frames, self.patch_start_idx, *grid, tokens.device)
        kept = []
        for index, block in enumerate(self.decoder):
            if index % 2 == 0:
                hidden = block(hidden.reshape(frames, count, dim), positions)
            else:
                hidden = block(hidden.reshape(batch, views * count, dim), positions.reshape(batch, -1, 2))
            if after_block is not None:
                hidden = after_block(index, hidden.reshape(batch, views, count, dim))
            if index >= len(self.decoder) - 2:
                kept.append(hidden.reshape(frames, count, dim))
        return torch.cat(kept, dim=-1), positions

    def cameras(self, features: torch.Tensor, positions: torch.Tensor, views: int) -> torch.Tensor:
        """(B, N, 4, 4) camera-to-world poses from the camera head transformer's patch tokens."""
        camera = self.camera_decoder(features, positions)[:, self.patch_start_idx :]
        return self.camera_head(camera.float()).reshape(-1, views, 4, 4)


class Pi3(Pi3Trunk):
    def __init__(self, config: Pi3Config | None = None) -> None:
        super().__init__(replace(config or Pi3Config.full_size("pi3"), arch="pi3"))
        patch = self.config.patch_size
        self.point_head = PatchLinearHead(self.config.point_decoder_out_dim, patch, 3)
        self.conf_head = PatchLinearHead(self.config.conf_decoder_out_dim, patch, 1)

    def forward(self, images: torch.Tensor) -> dict[str, torch.Tensor]:
        """images (B, N, 3, H, W) in [0, 1] -> points, local_points (B, N, H, W, 3), conf (B, N, H, W, 1)
        logits, camera_poses (B, N, 4, 4) camera-to-world (OpenCV axes)."""
        views, grid = images.shape[1], self.grid(images)
        features, positions = self.decode(self.encode_images(images), views, grid)
        start = self.patch_start_idx
        point = self.point_decoder(features, positions)[:, start:]
        conf = self.conf_decoder(features, positions)[:, start:]
        shape = (-1, views, *images.shape[-2:])
        with torch.autocast(device_type=images.device.type, enabled=False):
            xy, z = self.point_head(point.float(), *grid).reshape(*shape, 3).split((2, 1), dim=-1)
            local = torch.cat((xy * torch.exp(z), torch.exp(z)), dim=-1)
            poses = self.cameras(features, positions, views)
            return {
                "points": transform_points(poses, local),
                "local_points": local,
                "conf": self.conf_head(conf.float(), *grid).reshape(*shape, 1),
                "camera_poses": poses,
            }


class Pi3X(Pi3Trunk):
    """Pi3 with conv heads, a metric head and (when `multimodal`) conditioning on cameras and depth."""

    def __init__(self, config: Pi3Config | None = None, multimodal: bool = True) -> None:
        super().__init__(replace(config or Pi3Config.full_size("pi3x"), arch="pi3x"))
        config, dim = self.config, self.config.decoder_dim
        self.multimodal = multimodal
        self.point_head = ConvHead(config.point_decoder_out_dim, config.conv_head, (2, 1), config.patch_size)
        self.conf_head = ConvHead(config.conf_decoder_out_dim, config.conv_head, (1,), config.patch_size)
        self.metric_token = nn.Parameter(torch.zeros(1, 1, 2 * dim))
        self.metric_decoder = MetricDecoder(2 * dim, config.metric_decoder, config.metric_out_dim, self.rope)
        self.metric_head = nn.Linear(config.metric_out_dim, 1)
        if multimodal:
            self.depth_encoder = self._encoder(in_chans=2)
            self.depth_emb = nn.Parameter(torch.zeros(1, 1, dim))
            self.ray_embed = RayEmbedding(config.patch_size, dim, in_chans=2)
            self.pose_inject_blk = nn.ModuleList(
                PoseInjectBlock(
                    dim, config.pose_inject_heads, config.decoder.mlp_ratio, config.decoder_init_values
                )
                for _ in config.pose_inject_after
            )

    def add_conditions(self, tokens: torch.Tensor, conditions: Conditions) -> torch.Tensor:
        """Encoder tokens plus the ray and depth embeddings of the views whose mask is set."""
        frames = tokens.shape[0]
        if conditions.ray_mask.any():
            rays = conditions.rays.reshape(frames, *conditions.rays.shape[2:]).permute(0, 3, 1, 2)
            ray_mask = conditions.ray_mask.reshape(frames, 1, 1)
            tokens = tokens + self.ray_embed(rays.to(tokens.dtype)) * ray_mask
        if conditions.depth_mask.any():
            depth = self.depth_encoder(conditions.depths.to(tokens.dtype)) + self.depth_emb
            tokens = tokens + depth * conditions.depth_mask.reshape(frames, 1, 1)
        return tokens

    def pose_injection(self, conditions: Conditions, grid: tuple[int, int]) -> AfterBlock | None:
        """The decoder hook that adds pose-injection outputs to posed views' patch tokens."""
        if not conditions.pose_mask.any():
            return None
        after = {block: k for k, block in enumerate(self.config.pose_inject_after)}
        start, patches = self.patch_start_idx, grid[0] * grid[1]
        mask = view_pair_mask(conditions.pose_mask, patches)
        weight = conditions.pose_mask[:, :, None, None]

        def inject(index: int, hidden: torch.Tensor) -> torch.Tensor:
            if index not in after:
                return hidden
            batch, views, _, dim = hidden.shape
            patch_tokens = hidden[:, :, start:].reshape(batch, views * patches, dim)
            update = self.pose_inject_blk[after[index]](patch_tokens, conditions.poses, grid, mask)
            update = update.reshape(batch, views, patches, dim) * weight
            return torch.cat((hidden[:, :, :start], hidden[:, :, start:] + update), dim=2)

        return inject

    def forward(
        self,
        images: torch.Tensor,
        intrinsics: torch.Tensor | None = None,
        poses: torch.Tensor | None = None,
        depths: torch.Tensor | None = None,
        masks: tuple[torch.Tensor | None, torch.Tensor | None, torch.Tensor | None] = (None, None, None),
    ) -> dict[str, torch.Tensor]:
        """images (B, N, 3, H, W) in [0, 1]; optional intrinsics (B, N, 3, 3) in pixels of these
        images, poses (B, N, 4, 4) camera-to-world (OpenCV), depths (B, N, H, W) (0 = unknown) and
        per-view masks (depth, ray, pose), each (B, N) bool (default: every view of a given condition).

        Returns Pi3's outputs, metric-scaled, plus `metric` (B,) and `rays` (B, N, H, W, 3) unit
        camera-frame directions.
        """
        views, grid = images.shape[1], self.grid(images)
        tokens, after_block = self.encode_images(images), None
        given = intrinsics is not None or poses is not None or depths is not None
        if self.multimodal:
            shape = (images.shape[0], views, *images.shape[-2:])
            conditions = prepare_conditions(shape, images.device, intrinsics, poses, depths, masks)
            tokens = self.add_conditions(tokens, conditions)
            after_block = self.pose_injection(conditions, grid)
        elif given:
            raise ValueError("this Pi3X was loaded without its conditioning branch; it takes images only")
        features, positions = self.decode(tokens, views, grid, after_block)
        return self.heads(features, positions, images, grid)

    def metric_scale(self, features: torch.Tensor, positions: torch.Tensor, batch: int) -> torch.Tensor:
        """(B,) positive factor that makes the reconstruction metric."""
        context = features.reshape(batch, -1, features.shape[-1])
        # The metric token sits at the registers' place (0, 0): rotary positions leave it unrotated.
        query_pos = torch.zeros(batch, 1, 2, dtype=positions.dtype, device=positions.device)
        out = self.metric_decoder(
            self.metric_token.expand(batch, -1, -1), context, query_pos, positions.reshape(batch, -1, 2)
        )
        return torch.exp(self.metric_head(out.float()).reshape(batch))

    def heads(
        self, features: torch.Tensor, positions: torch.Tensor, images: torch.Tensor, grid: tuple[int, int]
    ) -> dict[str, torch.Tensor]:
        batch, views = images.shape[:2]
        start, shape = self.patch_start_idx, (batch, views, *images.shape[-2:])
        point = self.point_decoder(features, positions)[:, start:]
        conf = self.conf_decoder(features, positions)[:, start:]
        with torch.autocast(device_type=images.device.type, enabled=False):
            xy, z = (m.permute(0, 2, 3, 1).reshape(*shape, -1) for m in self.point_head(point.float(), *grid))
            depth = torch.exp(z.clamp(max=MAX_LOG_DEPTH))
            local = torch.cat((xy * depth, depth), dim=-1)
            poses = self.cameras(features, positions, views)
            metric = self.metric_scale(features, positions, batch)
            scale = metric[:, None, None, None, None]
            poses[..., :3, 3] = poses[..., :3, 3] * metric[:, None, None]
            return {
                "points": transform_points(poses, local * scale),
                "local_points": local * scale,
                "rays": F.normalize(torch.cat((xy, torch.ones_like(depth)), dim=-1), dim=-1),
                "conf": self.conf_head(conf.float(), *grid)[0].permute(0, 2, 3, 1).reshape(*shape, 1),
                "camera_poses": poses,
                "metric": metric,
            }
