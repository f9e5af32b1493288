"""Sizes of a VGGT model. The defaults are VGGT-1B; a JSON file can describe a reduced model."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from services.recon.backbones.transformer.dinov2 import DinoV2Sizes


class VGGTConfigError(ValueError):
    """A configuration file or mapping does not describe a VGGT model this code can build."""


@dataclass(frozen=True)
class PatchEmbedConfig:
    """The DINOv2-with-registers vision transformer that turns each image into patch tokens."""

    kind: str = "dinov2_reg"
    embed_dim: int = 1024
    depth: int = 24
    num_heads: int = 16
    mlp_ratio: float = 4.0
    init_values: float = 1.0
    interpolate_antialias: bool = True
    interpolate_offset: float = 0.0


@dataclass(frozen=True)
class CameraHeadConfig:
    dim_in: int = 2048
    trunk_depth: int = 4
    num_heads: int = 16
    mlp_ratio: float = 4.0
    init_values: float = 0.01
    num_iterations: int = 4


@dataclass(frozen=True)
class DPTHeadConfig:
    dim_in: int = 2048
    features: int = 256
    out_channels: tuple[int, int, int, int] = (256, 512, 1024, 1024)
    intermediate_layer_idx: tuple[int, int, int, int] = (4, 11, 17, 23)
    frames_chunk_size: int = 8  # frames decoded at once; only bounds memory, never changes results


@dataclass(frozen=True)
class VGGTConfig:
    img_size: int = 518
    patch_size: int = 14
    embed_dim: int = 1024
    depth: int = 24  # frame blocks; there are as many global blocks
    num_heads: int = 16
    mlp_ratio: float = 4.0
    num_register_tokens: int = 4
    qk_norm: bool = True
    rope_freq: float = 100.0
    init_values: float = 0.01
    patch_embed: PatchEmbedConfig = field(default_factory=PatchEmbedConfig)
    camera_head: CameraHeadConfig = field(default_factory=CameraHeadConfig)
    dpt_head: DPTHeadConfig = field(default_factory=DPTHeadConfig)

    def __post_init__(self) -> None:
        if self.patch_embed.kind != "dinov2_reg":
            raise VGGTConfigError(f"patch_embed.kind {self.patch_embed.kind!r} is not supported")
        if self.patch_embed.embed_dim != self.embed_dim:
            raise VGGTConfigError("patch_embed.embed_dim must equal embed_dim")
        if self.embed_dim % self.num_heads or (self.embed_dim // self.num_heads) % 4:
            raise VGGTConfigError("embed_dim / num_heads must be a multiple of 4 (2D rotary embedding)")
        for head in (self.camera_head.dim_in, self.dpt_head.dim_in):
            if head != 2 * self.embed_dim:
                raise VGGTConfigError("head dim_in must be 2 * embed_dim (frame and global tokens)")
        if max(self.dpt_head.intermediate_layer_idx) >= self.depth:
            raise VGGTConfigError("dpt_head.intermediate_layer_idx refers to a block that does not exist")

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> VGGTConfig:
        nested = {"patch_embed": PatchEmbedConfig, "camera_head": CameraHeadConfig, "dpt_head": DPTHeadConfig}
        arguments: dict[str, Any] = {}
        _reject_unknown(cls, values, "config")
        for key, value in values.items():
            if key in nested:
                _reject_unknown(nested[key], value, key)
                part = {k: tuple(v) if isinstance(v, list) else v for k, v in value.items()}
                arguments[key] = nested[key](**part)
            else:
                arguments[key] = value
        return cls(**arguments)

    @classmethod
    def from_json(cls, path: str | Path) -> VGGTConfig:
        try:
            values = json.loads(Path(path).read_text())
        except (OSError, json.JSONDecodeError) as error:
            raise VGGTConfigError(f"cannot read VGGT config {path}: {error}") from error
        if not isinstance(values, dict):
            raise VGGTConfigError(f"VGGT config {path} is not a JSON object")
        return cls.from_dict(values)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def patch_embed_sizes(self) -> DinoV2Sizes:
        """The patch embedder as the shared DINOv2 module takes it (with the mask token VGGT keeps)."""
        embed = self.patch_embed
        return DinoV2Sizes(
            embed_dim=embed.embed_dim,
            depth=embed.depth,
            num_heads=embed.num_heads,
            mlp_ratio=embed.mlp_ratio,
            init_values=embed.init_values,
            img_size=self.img_size,
            patch_size=self.patch_size,
            num_register_tokens=self.num_register_tokens,
            interpolate_antialias=embed.interpolate_antialias,
            interpolate_offset=embed.interpolate_offset,
        )

    def fingerprint(self) -> str:
        """A short hash of every size, so that versions change when the architecture does."""
        canonical = json.dumps(self.to_dict(), sort_keys=True, default=list)
        return hashlib.sha256(canonical.encode()).hexdigest()[:8]


def _reject_unknown(kind: type, values: Any, where: str) -> None:
    if not isinstance(values, dict):
        raise VGGTConfigError(f"{where} must be a JSON object")
    known = {f.name for f in fields(kind)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise VGGTConfigError(f"unknown keys in {where}: {', '.join(unknown)}")
