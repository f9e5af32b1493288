"""The size descriptions the shared transformer parts are built from."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TransformerSizes:
    """Width, number of blocks, heads and MLP ratio of a stack of transformer blocks."""

    embed_dim: int
    depth: int
    num_heads: int
    mlp_ratio: float = 4.0


@dataclass(frozen=True)
class DinoV2Config:
    """A DINOv2-with-registers encoder (defaults: ViT-L/14). Field names are VGGT's config keys."""

    kind: str = "dinov2_reg"
    embed_dim: int = 1024
    depth: int = 24
    num_heads: int = 16
    mlp_ratio: float = 4.0
    init_values: float = 1.0
    interpolate_antialias: bool = True
    interpolate_offset: float = 0.0
