"""Write a Pi3 / Pi3X fixture folder of another shape and other weights, in the format of
tests/data/pi3/ (see its README.md), so that the Pi3 tests can be run on it:

    PYTHONPATH=. .venv/bin/python scripts/make_pi3_fixture.py /tmp/pi3_other --views 4 \
        --height 56 --width 84 --decoder-depth 10 --seed 7
    PYSPATIAL_PI3_FIXTURES=/tmp/pi3_other .venv/bin/python -m pytest tests/test_pi3_*.py -q

The expected outputs are OUR model's outputs on the new weights: the folder checks that the tests
derive what they expect from the fixture files (view count, image size, tensor counts), not that
our model matches the published one (the shipped fixture, made with the published code, does that).
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import numpy as np
import torch
from safetensors.torch import save_file

from services.recon.backbones.pi3.config_file import read_pi3_config
from services.recon.backbones.pi3.model import Pi3, Pi3X

SHIPPED = Path(__file__).resolve().parent.parent / "tests" / "data" / "pi3"
# case suffix -> (conditions passed, depth / ray / pose masks as a function of the view count)
CASES = {
    "": ((), lambda n: ([False] * n, [False] * n, [False] * n)),
    "_intrinsics": (("intrinsics",), lambda n: ([False] * n, [True] * n, [False] * n)),
    "_intrinsics_poses": (("intrinsics", "poses"), lambda n: ([False] * n, [True] * n, [True] * n)),
    "_intrinsics_poses_depths": (("intrinsics", "poses", "depths"), lambda n: ([True] * n,) * 3),
    "_partial": (
        ("intrinsics", "poses", "depths"),
        lambda n: (
            [i % 3 != 0 for i in range(n)],
            [i % 3 != 2 for i in range(n)],
            [i % 3 != 1 for i in range(n)],
        ),
    ),
}


def write_config(out: Path, arch: str, decoder_depth: int) -> None:
    values = json.loads((SHIPPED / f"tiny_{arch}_config.json").read_text())
    values["decoder"]["depth"] = decoder_depth
    if arch == "pi3x":
        after = [index for index in range(1, decoder_depth - 1, 2)][:4]
        values["multimodal"]["pose_inject_after_decoder_blocks"] = after
        values["multimodal"]["pose_inject_blocks"] = len(after)
    (out / f"tiny_{arch}_config.json").write_text(json.dumps(values, indent=1))


def random_weights(model: torch.nn.Module, generator: torch.Generator) -> dict[str, torch.Tensor]:
    """Every tensor non-trivial (layer-scales and zero-initialised embeddings included)."""
    state = {}
    for name, tensor in model.state_dict().items():
        if name in ("image_mean", "image_std"):
            state[name] = tensor.clone()
            continue
        noise = torch.randn(tensor.shape, generator=generator) * 0.05
        state[name] = (tensor.float() + noise).contiguous()
    return state


def camera_conditions(views: int, height: int, width: int, generator: np.random.Generator) -> dict:
    focal = width * generator.uniform(0.9, 1.3, views)
    intrinsics = np.zeros((views, 3, 3), np.float32)
    intrinsics[:, 0, 0], intrinsics[:, 1, 1], intrinsics[:, 2, 2] = focal, focal, 1.0
    intrinsics[:, 0, 2], intrinsics[:, 1, 2] = width / 2, height / 2
    poses = np.tile(np.eye(4, dtype=np.float32), (views, 1, 1))
    for index in range(views):
        angle = 0.2 * index
        poses[index, :3, :3] = [
            [np.cos(angle), 0, np.sin(angle)],
            [0, 1, 0],
            [-np.sin(angle), 0, np.cos(angle)],
        ]
        poses[index, :3, 3] = generator.normal(0, 0.3, 3)
    depths = generator.uniform(1.0, 4.0, (views, height, width)).astype(np.float32)
    depths[generator.random(depths.shape) < 0.1] = 0.0
    return {"intrinsics": intrinsics, "poses": poses, "depths": depths}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--views", type=int, default=4)
    parser.add_argument("--height", type=int, default=56, help="a multiple of 14")
    parser.add_argument("--width", type=int, default=84, help="a multiple of 14")
    parser.add_argument("--decoder-depth", type=int, default=10)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    from tests.support import pi3_fixtures as fx  # the same recording the tests compare with

    args.out.mkdir(parents=True, exist_ok=True)
    for name in ("README.md", "pi3_state_dict.txt", "pi3x_state_dict.txt"):
        shutil.copy(SHIPPED / name, args.out / name)
    rng = np.random.default_rng(args.seed)
    images = rng.random((args.views, 3, args.height, args.width)).astype(np.float32)
    np.save(args.out / "tiny_pi3_input.npy", images)
    given = camera_conditions(args.views, args.height, args.width, rng)
    for name, value in given.items():
        np.save(args.out / f"tiny_pi3x_{name}.npy", value)
    generator = torch.Generator().manual_seed(args.seed)
    batch = torch.from_numpy(images)[None]
    for arch, build in (("pi3", Pi3), ("pi3x", Pi3X)):
        write_config(args.out, arch, args.decoder_depth)
        model = build(read_pi3_config(args.out / f"tiny_{arch}_config.json"))
        state = random_weights(model, generator)
        save_file(state, str(args.out / f"tiny_{arch}.safetensors"))
        model.load_state_dict(state)
        model.eval()
        cases = CASES if arch == "pi3x" else {"": CASES[""]}
        for case, (passed, masks_of) in cases.items():
            masks = tuple(torch.tensor([m]) for m in masks_of(args.views))
            kwargs = {name: torch.from_numpy(given[name])[None] for name in passed}
            if arch == "pi3x":
                kwargs["masks"] = masks
            patches = _NoPatch()
            recorded = fx.run_recording(model, batch, patches, **kwargs)
            patches.undo()
            if arch == "pi3x":
                for kind, mask in zip(("depth", "ray", "pose"), masks, strict=True):
                    recorded[f"mask_add_{kind}"] = mask.numpy()
            np.savez(args.out / f"tiny_{arch}_expected{case}.npz", **recorded)
    print(f"wrote {args.out}")


class _NoPatch:
    """pytest's monkeypatch, enough of it for one recording outside pytest."""

    def __init__(self) -> None:
        self._undo: list = []

    def setattr(self, target: object, name: str, value: object) -> None:
        self._undo.append((target, name, getattr(target, name)))
        setattr(target, name, value)

    def undo(self) -> None:
        for target, name, value in reversed(self._undo):
            setattr(target, name, value)


if __name__ == "__main__":
    main()
