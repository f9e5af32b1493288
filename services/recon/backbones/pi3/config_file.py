"""Read a Pi3 / Pi3X configuration written in the reference fixtures' JSON format.

That format names every size and also states facts this implementation builds in (biases,
norms, QK-norm, layer scale, UV inputs, ...). Sizes become a `Pi3Config`; a stated fact that
differs from what the code computes, a missing key or an unknown key is an error, so a file never
silently describes a model other than the one that is built. Descriptions (free text) and the
`full_size_values` summary are not read.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from services.recon.backbones.pi3.config import (
    IMAGENET_MEAN,
    IMAGENET_STD,
    ConvHeadSizes,
    Pi3Config,
    Pi3ConfigError,
)
from services.recon.backbones.transformer.checkpoint import read_json_object
from services.recon.backbones.transformer.sizes import DinoV2Config, TransformerSizes

DESCRIPTIONS = {"output", "alternation", "rotation", "res_block_norm", "depth_encoder", "full_size_values"}


class _Reader:
    """Takes values out of a nested JSON object by dotted path and remembers what was taken."""

    def __init__(self, values: dict[str, Any]) -> None:
        self.values = values
        self.taken: set[str] = set()

    def get(self, path: str) -> Any:
        node: Any = self.values
        for part in path.split("."):
            if not isinstance(node, dict) or part not in node:
                raise Pi3ConfigError(f"Pi3 config lacks {path}")
            node = node[part]
        self.taken.add(path)
        return node

    def expect(self, path: str, value: Any) -> None:
        given = self.get(path)
        if given != value and not (isinstance(value, tuple) and tuple(given) == value):
            raise Pi3ConfigError(
                f"Pi3 config says {path} = {given!r}; this implementation computes {value!r}"
            )

    def leftovers(self) -> list[str]:
        found: list[str] = []

        def walk(node: Any, prefix: str) -> None:
            for key, value in node.items():
                path = f"{prefix}{key}"
                if key in DESCRIPTIONS or path in self.taken:
                    continue
                if isinstance(value, dict) and any(t.startswith(path + ".") for t in self.taken):
                    walk(value, path + ".")
                else:
                    found.append(path)

        walk(self.values, "")
        return sorted(found)


def _encoder(read: _Reader) -> dict[str, Any]:
    read.expect("encoder.kind", "dinov2_with_registers")
    for path, value in (("qkv_bias", True), ("layer_norm_eps", 1e-6), ("ffn", "mlp_gelu")):
        read.expect(f"encoder.{path}", value)
    read.expect("encoder.has_mask_token", False)
    read.expect("encoder.patch_size", read.get("patch_size"))
    names = ("embed_dim", "depth", "num_heads", "mlp_ratio", "init_values", "interpolate_antialias")
    encoder = DinoV2Config(
        **{name: read.get(f"encoder.{name}") for name in names},
        interpolate_offset=read.get("encoder.interpolate_offset"),
    )
    return {
        "encoder": encoder,
        "encoder_img_size": read.get("encoder.img_size"),
        "encoder_registers": read.get("encoder.num_register_tokens"),
    }


def _sizes(read: _Reader, part: str) -> TransformerSizes:
    return TransformerSizes(
        *(read.get(f"{part}.{n}") for n in ("embed_dim", "depth", "num_heads", "mlp_ratio"))
    )


def _decoder(read: _Reader) -> dict[str, Any]:
    for path, value in (
        ("qk_norm", True),
        ("qkv_bias", True),
        ("layer_norm_eps", 1e-6),
        ("layerscale", True),
    ):
        read.expect(f"decoder.{path}", value)
    dim = read.get("decoder.embed_dim")
    read.expect("head_decoder.in_dim", 2 * dim)
    read.expect("head_decoder.qk_norm", False)
    read.expect("head_decoder.layerscale", False)
    read.expect("head_decoder.rope_freq", read.get("decoder.rope_freq"))
    read.expect("camera_head.dim", read.get("camera_decoder_out_dim"))
    read.expect("camera_head.num_res_blocks", 2)
    return {
        "decoder": _sizes(read, "decoder"),
        "decoder_init_values": read.get("decoder.init_values"),
        "rope_freq": read.get("decoder.rope_freq"),
        "num_register_tokens": read.get("decoder.num_register_tokens"),
        "head_decoder": _sizes(read, "head_decoder"),
        "point_decoder_out_dim": read.get("point_decoder_out_dim"),
        "conf_decoder_out_dim": read.get("conf_decoder_out_dim"),
        "camera_decoder_out_dim": read.get("camera_decoder_out_dim"),
    }


def _linear_heads(read: _Reader, patch: int) -> None:
    for head, channels in (("point_head", 3), ("conf_head", 1)):
        read.expect(f"{head}.kind", f"linear + pixel_shuffle({patch})")
        read.expect(f"{head}.in_dim", read.get(f"{head.split('_')[0]}_decoder_out_dim"))
        read.expect(f"{head}.out_channels", channels)


def _conv_heads(read: _Reader) -> ConvHeadSizes:
    sizes = None
    for head, outputs in (("point_head", (2, 1)), ("conf_head", (1,))):
        read.expect(f"{head}.kind", "conv_upsample_head")
        read.expect(f"{head}.dim_proj", read.get(f"{head.split('_')[0]}_decoder_out_dim"))
        for path, value in (("last_conv_size", 1), ("last_res_blocks", 0), ("using_uv", True)):
            read.expect(f"{head}.{path}", value)
        read.expect(f"{head}.padding_mode", "replicate")
        read.expect(f"{head}.dim_out", outputs)
        these = ConvHeadSizes(
            dim_upsample=tuple(read.get(f"{head}.dim_upsample")),
            dim_times_res_block_hidden=read.get(f"{head}.dim_times_res_block_hidden"),
            num_res_blocks=read.get(f"{head}.num_res_blocks"),
            last_conv_channels=read.get(f"{head}.last_conv_channels"),
        )
        if sizes is not None and these != sizes:
            raise Pi3ConfigError("point_head and conf_head must have the same upsampling sizes")
        sizes = these
    assert sizes is not None
    return sizes


def _metric_and_conditions(read: _Reader, dim: int, patch: int) -> dict[str, Any]:
    read.expect("metric_decoder.kind", "cross-attention only (metric token queries all tokens of all views)")
    read.expect("metric_decoder.in_dim", 2 * dim)
    read.expect("metric_token_dim", 2 * dim)
    read.expect("multimodal.ray_embed.in_chans", 2)
    read.expect("multimodal.ray_embed.patch_size", patch)
    read.expect("multimodal.ray_embed.embed_dim", dim)
    read.expect("multimodal.depth_emb_dim", dim)
    after = tuple(read.get("multimodal.pose_inject_after_decoder_blocks"))
    read.expect("multimodal.pose_inject_blocks", len(after))
    return {
        "metric_decoder": _sizes(read, "metric_decoder"),
        "metric_out_dim": read.get("metric_decoder.out_dim"),
        "pose_inject_after": after,
        "pose_inject_heads": read.get("multimodal.pose_inject_num_heads"),
    }


def config_from_fixture_format(values: dict[str, Any]) -> Pi3Config:
    read = _Reader(values)
    arch = read.get("arch")
    read.expect("image_normalization.mean", IMAGENET_MEAN)
    read.expect("image_normalization.std", IMAGENET_STD)
    patch = read.get("patch_size")
    arguments: dict[str, Any] = {
        "arch": arch,
        "patch_size": patch,
        **_encoder(read),
        **_decoder(read),
    }
    if arch == "pi3x":
        arguments["conv_head"] = _conv_heads(read)
        arguments.update(_metric_and_conditions(read, arguments["decoder"].embed_dim, patch))
    else:
        _linear_heads(read, patch)
    unknown = read.leftovers()
    if unknown:
        raise Pi3ConfigError(f"unknown keys in Pi3 config: {', '.join(unknown)}")
    try:
        return Pi3Config(**arguments)
    except TypeError as error:
        raise Pi3ConfigError(f"bad Pi3 config: {error}") from error


def read_pi3_config(path: str | Path) -> Pi3Config:
    """A `Pi3Config` from a JSON file in the fixtures' format; Pi3ConfigError says what is wrong."""
    values = read_json_object(path, "Pi3 config", Pi3ConfigError)
    return config_from_fixture_format(values)
