"""Sizes of a VGGT model. The defaults are VGGT-1B; a JSON file can describe a reduced model."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from services.recon.backbones.transformer.checkpoint import read_json_object
from services.recon.backbones.transformer.sizes import DinoV2Config


class VGGTConfigError(ValueError):
    """A configuration file or mapping does not describe a VGGT model this code can build."""


# The patch embedder is the shared DINOv2 encoder; its JSON keys are that description's fields.
PatchEmbedConfig = DinoV2Config


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
        values = read_json_object(path, "VGGT config", VGGTConfigError)
        return cls.from_dict(values)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

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
