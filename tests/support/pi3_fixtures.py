"""The Pi3 / Pi3X reference fixtures (tests/data/pi3/, see its README.md) and a run of our models
that records the same intermediate arrays the fixtures store (`debug_*`), through forward hooks.

`PYSPATIAL_PI3_FIXTURES` points the tests at another fixture folder of the same format (other
weights, view count, image size; `scripts/make_pi3_fixture.py` writes one): what the tests expect
is read from the folder's files, never from the shipped fixture's numbers.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import torch

from services.recon.backbones.pi3 import model as pi3_model
from services.recon.backbones.pi3.checkpoint import load_pi3
from services.recon.backbones.pi3.config import Pi3Config
from services.recon.backbones.pi3.config_file import read_pi3_config

SHIPPED = Path(__file__).resolve().parent.parent / "data" / "pi3"
DATA = Path(os.environ.get("PYSPATIAL_PI3_FIXTURES") or SHIPPED)
# case suffix -> which conditions the fixture passed
PI3X_CASES = {
    "": (),
    "_intrinsics": ("intrinsics",),
    "_intrinsics_poses": ("intrinsics", "poses"),
    "_intrinsics_poses_depths": ("intrinsics", "poses", "depths"),
    "_partial": ("intrinsics", "poses", "depths"),
}


def tiny_config(arch: str) -> Pi3Config:
    return read_pi3_config(DATA / f"tiny_{arch}_config.json")


def tiny_model(arch: str) -> Any:
    return load_pi3(DATA / f"tiny_{arch}.safetensors", tiny_config(arch))


def images() -> torch.Tensor:
    return torch.from_numpy(np.load(DATA / "tiny_pi3_input.npy"))[None]


def input_shape() -> tuple[int, int, int]:
    """(views, height, width) of the fixture's images."""
    views, _channels, height, width = np.load(DATA / "tiny_pi3_input.npy", mmap_mode="r").shape
    return int(views), int(height), int(width)


def input_pixels() -> int:
    """The fixture images' own pixel count: a pixel limit at which preprocessing keeps them as they are."""
    _views, height, width = input_shape()
    return height * width


def config_values(arch: str) -> dict[str, Any]:
    return json.loads((DATA / f"tiny_{arch}_config.json").read_text())


def tensor_names(arch: str) -> set[str]:
    from safetensors import safe_open

    with safe_open(str(DATA / f"tiny_{arch}.safetensors"), framework="pt") as handle:
        return set(handle.keys())


def expected(arch: str, case: str = "") -> dict[str, np.ndarray]:
    with np.load(DATA / f"tiny_{arch}_expected{case}.npz") as arrays:
        return {name: arrays[name] for name in arrays.files}


def conditions(case: str, reference: dict[str, np.ndarray]) -> dict[str, Any]:
    """Keyword arguments of Pi3X.forward for one fixture case (batch axis added, masks as stored)."""
    given = {
        name: torch.from_numpy(np.load(DATA / f"tiny_pi3x_{name}.npy"))[None] for name in PI3X_CASES[case]
    }
    masks = tuple(torch.from_numpy(reference[f"mask_add_{kind}"]) for kind in ("depth", "ray", "pose"))
    return {**given, "masks": masks}


def _hook(store: dict[str, Any], name: str):
    return lambda _module, _inputs, output: store.__setitem__(name, output)


def run_recording(model: Any, inputs: torch.Tensor, monkeypatch: Any, **kwargs: Any) -> dict[str, np.ndarray]:
    """Outputs and the fixtures' intermediate arrays of one forward pass, as numpy."""
    store: dict[str, Any] = {}
    handles = [model.encoder.register_forward_hook(_hook(store, "debug_encoder_patch_tokens"))]
    for module, name in (
        ("point_decoder", "point_decoder_out"),
        ("conf_decoder", "conf_decoder_out"),
        ("camera_decoder", "camera_decoder_out"),
        ("metric_decoder", "metric_decoder_out"),
        ("ray_embed", "ray_embed_out"),
        ("depth_encoder", "depth_encoder_patch_tokens"),
    ):
        if hasattr(model, module):
            handles.append(getattr(model, module).register_forward_hook(_hook(store, f"debug_{name}")))
    for index, block in enumerate(getattr(model, "pose_inject_blk", [])):
        handles.append(block.register_forward_hook(_hook(store, f"debug_pose_inject_{index}_out")))
    decode, prepare = model.decode, pi3_model.prepare_conditions

    def recording_decode(tokens: torch.Tensor, *args: Any, **kw: Any) -> Any:
        store["debug_encoder_out_with_conditions"] = tokens
        features, positions = decode(tokens, *args, **kw)
        store["debug_decoder_out"], store["debug_token_pos"] = features, positions
        return features, positions

    def recording_prepare(*args: Any, **kw: Any) -> Any:
        prepared = prepare(*args, **kw)
        store["debug_normalized_poses"], store["debug_condition_scale"] = prepared.poses, prepared.scale
        return prepared

    monkeypatch.setattr(model, "decode", recording_decode)
    monkeypatch.setattr(pi3_model, "prepare_conditions", recording_prepare)
    try:
        with torch.inference_mode():
            outputs = model(inputs, **kwargs)
    finally:
        for handle in handles:
            handle.remove()
    return {name: value.numpy() for name, value in {**store, **outputs}.items()}


def assert_matches(actual: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> None:
    """Every stored array within the fixtures' tolerance (positions exactly), masks aside."""
    for name, wanted in reference.items():
        if name.startswith("mask_add_"):
            continue
        assert name in actual, f"{name} was not computed"
        got = actual[name].reshape(wanted.shape) if actual[name].size == wanted.size else actual[name]
        assert got.shape == wanted.shape, name
        if wanted.dtype.kind == "i":
            np.testing.assert_array_equal(got, wanted, err_msg=name)
            continue
        assert np.isfinite(got).all(), name
        np.testing.assert_allclose(got, wanted, rtol=1e-4, atol=1e-4 * np.abs(wanted).max(), err_msg=name)


def pi3_weights_read_as_pi3x() -> tuple[list[str], list[str]]:
    """(missing, unexpected) tensor names when the Pi3 weights are loaded into the Pi3X model: with
    no conditioning tensors the checkpoint is read as an images-only Pi3X, so those are not missing."""
    conditioning = tiny_config("pi3x").multimodal_prefixes
    pi3, pi3x = tensor_names("pi3"), tensor_names("pi3x")
    images_only = {name for name in pi3x if not name.startswith(conditioning)}
    return sorted(images_only - pi3), sorted(pi3 - pi3x)
