"""Pi3X's optional conditions, normalized the way the published model reads them.

- Intrinsics (pixels of the network image) become a 2-channel ray map per view: for pixel (u, v)
  (column, row), the first two components of K^-1 [u + 0.5, v + 0.5, 1].
- Depths (0 = unknown) are divided by s, the mean of every valid depth of the batch element
  (1 when there is none), and paired with their validity mask.
- Poses (camera-to-world, OpenCV axes) are made relative to view 0 and their translations divided
  by s; when no view has depth, also by the mean distance of views 1..N-1 from view 0 (unless
  the cameras hardly move), because poses are then the only scale there is.
- Masks are per view; a condition that is not given is masked off everywhere; a pose mask with
  a single view is no constraint (poses act only relatively) and counts as none.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from services.recon.backbones.pi3.pose_injection import invert_rigid

STATIC_TRANSLATION = 0.02  # below this (after depth normalization) the cameras count as not moving
EPSILON = 1e-8


@dataclass
class Conditions:
    rays: torch.Tensor  # (B, N, H, W, 2)
    depths: torch.Tensor  # (B*N, 2, H, W): normalized depth and validity
    poses: torch.Tensor  # (B, N, 4, 4) normalized camera-to-world
    scale: torch.Tensor  # (B,) the total divisor of the translations
    depth_mask: torch.Tensor  # (B, N) bool
    ray_mask: torch.Tensor
    pose_mask: torch.Tensor


def rays_from_intrinsics(intrinsics: torch.Tensor, height: int, width: int) -> torch.Tensor:
    """(B, N, 3, 3) pixel intrinsics -> (B, N, H, W, 2) ray directions (x/z, y/z) of pixel centres."""
    rows = torch.arange(height, dtype=torch.float32, device=intrinsics.device) + 0.5
    columns = torch.arange(width, dtype=torch.float32, device=intrinsics.device) + 0.5
    v, u = torch.meshgrid(rows, columns, indexing="ij")
    pixels = torch.stack((u, v, torch.ones_like(u)), dim=-1)
    return torch.einsum("bnij,hwj->bnhwi", torch.inverse(intrinsics.float()), pixels)[..., :2]


def depth_scale(depths: torch.Tensor) -> torch.Tensor:
    """(B, N, H, W) -> (B,) mean of the valid (> 0) depths of each batch element; 1 where none."""
    valid = depths > 0
    count = valid.flatten(1).sum(dim=1)
    total = torch.where(valid, depths, torch.zeros_like(depths)).flatten(1).sum(dim=1)
    return torch.where(count > 0, total / count.clamp(min=1), torch.ones_like(total))


def normalize_poses(
    poses: torch.Tensor, scale: torch.Tensor, depth_mask: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Relative, scale-normalized poses and the total divisor of their translations (B,)."""
    relative = invert_rigid(poses[:, :1]) @ poses
    relative[..., :3, 3] /= scale[:, None, None]
    divisor = scale.clone()
    if relative.shape[1] > 1:
        distances = relative[:, 1:, :3, 3].norm(dim=-1)
        moving = distances.max(dim=1).values >= STATIC_TRANSLATION
        rescale = ~depth_mask.any(dim=1) & moving
        mean = distances.mean(dim=1)
        factor = torch.where(rescale, mean + EPSILON, torch.ones_like(mean))
        relative[..., :3, 3] /= factor[:, None, None]
        divisor = divisor * torch.where(rescale, mean, torch.ones_like(mean))
    return relative, divisor


def _mask(
    mask: torch.Tensor | None, given: bool, shape: tuple[int, int], device: torch.device
) -> torch.Tensor:
    if not given:
        return torch.zeros(shape, dtype=torch.bool, device=device)
    if mask is None:
        return torch.ones(shape, dtype=torch.bool, device=device)
    return mask.to(device=device, dtype=torch.bool).clone()


def prepare_conditions(
    shape: tuple[int, int, int, int],
    device: torch.device,
    intrinsics: torch.Tensor | None = None,
    poses: torch.Tensor | None = None,
    depths: torch.Tensor | None = None,
    masks: tuple[torch.Tensor | None, torch.Tensor | None, torch.Tensor | None] = (None, None, None),
) -> Conditions:
    """shape (B, N, H, W); masks (depth, ray, pose), each (B, N) bool or None (every view)."""
    batch, views, height, width = shape
    depth_mask = _mask(masks[0], depths is not None, (batch, views), device)
    ray_mask = _mask(masks[1], intrinsics is not None, (batch, views), device)
    pose_mask = _mask(masks[2], poses is not None, (batch, views), device)
    pose_mask[pose_mask.sum(dim=1) == 1] = False
    if depths is None:
        depths = torch.zeros(shape, device=device)
    depths = depths.float().to(device)
    scale = depth_scale(depths)
    normalized = depths / (scale[:, None, None, None] + EPSILON)
    depth_input = torch.stack((normalized, (normalized > 0).float()), dim=2).reshape(-1, 2, height, width)
    if intrinsics is None:
        rays = torch.zeros(batch, views, height, width, 2, device=device)
    else:
        rays = rays_from_intrinsics(intrinsics.to(device), height, width)
    if poses is None:
        poses = torch.eye(4, device=device).expand(batch, views, 4, 4)
    relative, divisor = normalize_poses(poses.float().to(device), scale, depth_mask)
    return Conditions(rays, depth_input, relative, divisor, depth_mask, ray_mask, pose_mask)
