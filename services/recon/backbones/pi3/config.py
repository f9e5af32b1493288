"""Sizes of a Pi3 or Pi3X model. The defaults are the published full-size models; `config_file`
reads a reduced one from JSON in the reference fixtures' format (tests/data/pi3/tiny_pi3*_config.json).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from services.recon.backbones.transformer.dinov2 import DinoV2Sizes

Arch = Literal["pi3", "pi3x"]
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


class Pi3ConfigError(ValueError):
    """A configuration does not describe a Pi3 / Pi3X model this code can build."""


@dataclass(frozen=True)
class HeadDecoderSizes:
    """The small transformer in front of each head (points, confidence, camera)."""

    embed_dim: int = 1024
    depth: int = 5
    num_heads: int = 16
    mlp_ratio: float = 4.0


@dataclass(frozen=True)
class ConvHeadSizes:
    """Pi3X's convolutional upsampling heads (points and confidence)."""

    dim_upsample: tuple[int, ...] = (256, 128, 64)
    dim_times_res_block_hidden: int = 2
    num_res_blocks: int = 2
    last_conv_channels: int = 32


@dataclass(frozen=True)
class MetricDecoderSizes:
    """Pi3X's metric-scale decoder: one token cross-attends to every token of every view."""

    embed_dim: int = 512
    depth: int = 5
    num_heads: int = 8
    mlp_ratio: float = 4.0
    out_dim: int = 512


@dataclass(frozen=True)
class Pi3Config:
    arch: Arch = "pi3x"
    patch_size: int = 14
    encoder: DinoV2Sizes = field(default_factory=lambda: DinoV2Sizes(mask_token=False))
    decoder_dim: int = 1024
    decoder_depth: int = 36  # blocks alternate: even ones within each view, odd ones across views
    decoder_heads: int = 16
    decoder_mlp_ratio: float = 4.0
    decoder_init_values: float = 0.01
    rope_freq: float = 100.0
    num_register_tokens: int = 5
    head_decoder: HeadDecoderSizes = field(default_factory=HeadDecoderSizes)
    point_decoder_out_dim: int = 1024
    conf_decoder_out_dim: int = 1024
    camera_decoder_out_dim: int = 512  # also the camera head's width
    conv_head: ConvHeadSizes = field(default_factory=ConvHeadSizes)
    metric_decoder: MetricDecoderSizes = field(default_factory=MetricDecoderSizes)
    pose_inject_after: tuple[int, ...] = (1, 9, 17, 25, 33)
    pose_inject_heads: int = 16

    def __post_init__(self) -> None:
        if self.arch not in ("pi3", "pi3x"):
            raise Pi3ConfigError(f"arch must be 'pi3' or 'pi3x', not {self.arch!r}")
        if self.encoder.embed_dim != self.decoder_dim or self.encoder.patch_size != self.patch_size:
            raise Pi3ConfigError("the encoder's embed_dim and patch_size must be the decoder's")
        widths = [
            ("decoder", self.decoder_dim, self.decoder_heads),
            ("head_decoder", self.head_decoder.embed_dim, self.head_decoder.num_heads),
        ]
        if self.arch == "pi3x":
            widths.append(("metric_decoder", self.metric_decoder.embed_dim, self.metric_decoder.num_heads))
        for name, dim, heads in widths:
            if dim % heads or (dim // heads) % 4:
                raise Pi3ConfigError(f"{name}: embed_dim / num_heads must be a multiple of 4 (2D RoPE)")
        if self.decoder_depth < 2:
            raise Pi3ConfigError("decoder_depth must be at least 2 (the heads read the last two blocks)")
        if self.arch == "pi3x":
            if self.decoder_dim % self.pose_inject_heads or (self.decoder_dim // self.pose_inject_heads) % 8:
                raise Pi3ConfigError("pose injection: head width must be a multiple of 8 (projective RoPE)")
            if any(not 0 <= i < self.decoder_depth for i in self.pose_inject_after):
                raise Pi3ConfigError("pose_inject_after must name blocks of the decoder")

    @property
    def multimodal_prefixes(self) -> tuple[str, ...]:
        """Checkpoint prefixes of Pi3X's optional conditioning branch (intrinsics, poses, depths)."""
        return (
            ("depth_encoder.", "depth_emb", "ray_embed.", "pose_inject_blk.") if self.arch == "pi3x" else ()
        )

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def fingerprint(self) -> str:
        """A short hash of every size, so that versions change when the architecture does."""
        canonical = json.dumps(self.to_dict(), sort_keys=True, default=list)
        return hashlib.sha256(canonical.encode()).hexdigest()[:8]

    @classmethod
    def full_size(cls, arch: Arch) -> Pi3Config:
        return cls(arch=arch)
