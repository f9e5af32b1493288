"""Do the tiny reference fixtures come out the same on CUDA as on the CPU?

    python -m bench.cuda_parity [--devices cpu cuda]

The tests check our Pi3, Pi3X and VGGT against the reference architectures' recorded outputs
(tests/data/pi3, tests/data/vggt) on the CPU only, since CI has no GPU. This runs the same
fixture weights and inputs on each device in float32 (TF32 off, so CUDA's matrix products round
as float32 does) and under bf16 autocast (what the backbones use on CUDA), and prints, per
fixture and output, the largest error relative to the output's own range: float32 should stay
within the tests' 1e-4, bf16 within its 8-bit mantissa (about 1e-2).
"""

from __future__ import annotations

import argparse
from contextlib import nullcontext
from pathlib import Path

import numpy as np
import torch

from services.recon.backbones.pi3.checkpoint import load_pi3
from services.recon.backbones.pi3.config_file import read_pi3_config
from services.recon.backbones.vggt.checkpoint import load_vggt
from services.recon.backbones.vggt.config import VGGTConfig

DATA = Path(__file__).resolve().parent.parent / "tests" / "data"
PI3X_CONDITIONS = {  # fixture case suffix -> the conditions it passed (tests/support/pi3_fixtures.py)
    "": (),
    "_intrinsics": ("intrinsics",),
    "_intrinsics_poses": ("intrinsics", "poses"),
    "_intrinsics_poses_depths": ("intrinsics", "poses", "depths"),
}


def cases() -> list[tuple[str, object, torch.Tensor, dict, dict[str, np.ndarray]]]:
    """(name, model, images, forward keyword arguments, reference outputs) for every fixture."""
    pi3_dir, vggt_dir = DATA / "pi3", DATA / "vggt"
    images = torch.from_numpy(np.load(pi3_dir / "tiny_pi3_input.npy"))[None]
    found = []
    for arch, conditions in (("pi3", {"": ()}), ("pi3x", PI3X_CONDITIONS)):
        model = load_pi3(
            pi3_dir / f"tiny_{arch}.safetensors", read_pi3_config(pi3_dir / f"tiny_{arch}_config.json")
        )
        for case, names in conditions.items():
            with np.load(pi3_dir / f"tiny_{arch}_expected{case}.npz") as stored:
                reference = {name: stored[name] for name in stored.files}
            kwargs = {
                name: torch.from_numpy(np.load(pi3_dir / f"tiny_pi3x_{name}.npy"))[None] for name in names
            }
            if arch == "pi3x":
                kwargs["masks"] = tuple(
                    torch.from_numpy(reference[f"mask_add_{kind}"]) for kind in ("depth", "ray", "pose")
                )
            found.append((f"{arch}{case}", model, images, kwargs, reference))
    vggt = load_vggt(
        vggt_dir / "tiny_vggt.safetensors", VGGTConfig.from_json(vggt_dir / "tiny_vggt_config.json")
    )
    with np.load(vggt_dir / "tiny_vggt_expected.npz") as stored:
        reference = {name: stored[name] for name in stored.files}
    found.append(("vggt", vggt, torch.from_numpy(np.load(vggt_dir / "tiny_vggt_input.npy")), {}, reference))
    return found


def to_device(value: object, device: torch.device) -> object:
    if isinstance(value, torch.Tensor):
        return value.to(device)
    if isinstance(value, tuple):
        return tuple(to_device(item, device) for item in value)
    return value


def worst_errors(model, images, kwargs, reference, device: torch.device, bf16: bool) -> dict[str, float]:
    """Per model output that the fixture stores: max |ours - reference| / max |reference|."""
    model = model.to(device).eval()
    autocast = torch.autocast(device.type, dtype=torch.bfloat16) if bf16 else nullcontext()
    with torch.inference_mode(), autocast:
        outputs = model(images.to(device), **{k: to_device(v, device) for k, v in kwargs.items()})
    errors = {}
    for name, value in outputs.items():
        if name not in reference or not isinstance(value, torch.Tensor):
            continue
        ours = value.float().cpu().numpy().reshape(reference[name].shape)
        scale = max(float(np.abs(reference[name]).max()), 1e-12)
        errors[name] = float(np.abs(ours - reference[name]).max()) / scale
    return errors


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="pyspatial bench cuda_parity", description=__doc__)
    parser.add_argument(
        "--devices", nargs="+", default=["cpu", "cuda"] if torch.cuda.is_available() else ["cpu"]
    )
    args = parser.parse_args(argv)
    torch.backends.cuda.matmul.allow_tf32 = False
    torch.backends.cudnn.allow_tf32 = False
    print(
        f"torch {torch.__version__}"
        + (f", {torch.cuda.get_device_name()}" if torch.cuda.is_available() else "")
    )
    print("| fixture | device | precision | outputs | worst output | worst error / range |")
    print("| --- | --- | --- | ---: | --- | ---: |")
    for name, model, images, kwargs, reference in cases():
        for device_name in args.devices:
            for bf16 in (False, True) if device_name == "cuda" else (False,):
                errors = worst_errors(model, images, kwargs, reference, torch.device(device_name), bf16)
                worst = max(errors, key=errors.get)
                precision = "bf16 autocast" if bf16 else "float32"
                cells = (name, device_name, precision, len(errors), worst, f"{errors[worst]:.2e}")
                print("| " + " | ".join(str(cell) for cell in cells) + " |")


if __name__ == "__main__":
    main()
