"""Sizes of a Pi3 or Pi3X model. The defaults are the published full-size models; `config_file`
reads a reduced one from JSON in the reference fixtures' format (tests/data/pi3/tiny_pi3*_config.json).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from services.recon.backbones.transformer.sizes import DinoV2Config, TransformerSizes

Arch = Literal["pi3", "pi3x"]
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


class Pi3ConfigError(ValueError):
    """A configuration does not describe a Pi3 / Pi3X model this code can build."""


@dataclass(frozen=True)
class ConvHeadSizes:
    """Pi3X's convolutional upsampling heads (points and confidence)."""

    dim_upsample: tuple[int, ...] = (256, 128, 64)
    dim_times_res_block_hidden: int = 2
    num_res_blocks: int = 2
    last_conv_channels: int = 32


@dataclass(frozen=True)
class Pi3Config:
    arch: Arch = "pi3x"
    patch_size: int = 14
    encoder: DinoV2Config = field(default_factory=DinoV2Config)  # DINOv2-L/14, 518 px table, 4 registers
    encoder_img_size: int = 518
    encoder_registers: int = 4
    # The trunk: blocks alternate, even ones within each view, odd ones across all views.
    decoder: TransformerSizes = field(default_factory=lambda: TransformerSizes(1024, 36, 16))
    decoder_init_values: float = 0.01
    rope_freq: float = 100.0
    num_register_tokens: int = 5
    head_decoder: TransformerSizes = field(default_factory=lambda: TransformerSizes(1024, 5, 16))
    point_decoder_out_dim: int = 1024
    conf_decoder_out_dim: int = 1024
    camera_decoder_out_dim: int = 512  # also the camera head's width
    conv_head: ConvHeadSizes = field(default_factory=ConvHeadSizes)
    metric_decoder: TransformerSizes = field(default_factory=lambda: TransformerSizes(512, 5, 8))
    metric_out_dim: int = 512
    pose_inject_after: tuple[int, ...] = (1, 9, 17, 25, 33)
    pose_inject_heads: int = 16

    @property
    def decoder_dim(self) -> int:
        return self.decoder.embed_dim

    def __post_init__(self) -> None:
        if self.arch not in ("pi3", "pi3x"):
            raise Pi3ConfigError(f"arch must be 'pi3' or 'pi3x', not {self.arch!r}")
        if self.encoder.embed_dim != self.decoder_dim:
            raise Pi3ConfigError("the encoder's embed_dim must be the decoder's (its tokens enter the trunk)")
        widths = [
            ("decoder", self.decoder_dim, self.decoder.num_heads),
            ("head_decoder", self.head_decoder.embed_dim, self.head_decoder.num_heads),
        ]
        if self.arch == "pi3x":
            widths.append(("metric_decoder", self.metric_decoder.embed_dim, self.metric_decoder.num_heads))
        for name, dim, heads in widths:
            if dim % heads or (dim // heads) % 4:
                raise Pi3ConfigError(f"{name}: embed_dim / num_heads must be a multiple of 4 (2D RoPE)")
        if self.decoder.depth < 2:
            raise Pi3ConfigError("decoder_depth must be at least 2 (the heads read the last two blocks)")
        if self.arch == "pi3x":
            if self.decoder_dim % self.pose_inject_heads or (self.decoder_dim // self.pose_inject_heads) % 8:
                raise Pi3ConfigError("pose injection: head width must be a multiple of 8 (projective RoPE)")
            if any(not 0 <= i < self.decoder.depth for i in self.pose_inject_after):
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
