"""Forward time and peak memory of full-size Pi3X, Pi3 and VGGT-1B (random weights), side by side.

    flock /work/locks/heavy.lock .venv/bin/python -m bench.pi3 --views 4 8

Each (model, views) runs in its own child process, interleaved (pi3x, pi3, vggt at 4 views, then
at 8, ...), so every peak is that model's alone: peak resident memory is the child's VmHWM
(CPU); on CUDA, torch.cuda.max_memory_allocated. Inputs are each model's published input size
for a 640x480 photo: Pi3 / Pi3X resize to 574x434 (at most 255,000 pixels, multiples of 14), VGGT
to 518x392 (width 518, crop mode). Weights are drawn with a fixed seed, so no checkpoint is
needed; timings do not depend on the values. CPU runs float32; CUDA runs bf16 autocast as the
backbones do. Prints a markdown table.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from contextlib import nullcontext
from pathlib import Path
from typing import Any

import torch

from bench.vggt import fill_random

SIZES = {"pi3x": (574, 434), "pi3": (574, 434), "vggt": (518, 392)}  # (width, height) of a 640x480 photo
GIB = 1024**3


def build(name: str, device: torch.device) -> Any:
    with torch.device("meta"):
        if name == "vggt":
            from services.recon.backbones.vggt.config import VGGTConfig
            from services.recon.backbones.vggt.model import VGGT

            model = VGGT(VGGTConfig())
        else:
            from services.recon.backbones.pi3.model import Pi3, Pi3X

            model = Pi3X() if name == "pi3x" else Pi3()
    model = fill_random(model, device)
    if name != "vggt":
        from services.recon.backbones.pi3.config import IMAGENET_MEAN, IMAGENET_STD

        model.image_mean.copy_(torch.tensor(IMAGENET_MEAN).view(1, 3, 1, 1))
        model.image_std.copy_(torch.tensor(IMAGENET_STD).view(1, 3, 1, 1))
    return model


def peak_rss_bytes() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    return 0


def child(name: str, views: int, device_name: str) -> dict[str, Any]:
    """One model, one view count, in this (child) process."""
    device = torch.device(device_name)
    width, height = SIZES[name]
    images = torch.rand(1, views, 3, height, width, generator=torch.Generator().manual_seed(1)).to(device)
    if name == "vggt":
        images = images[0]
    started = time.perf_counter()
    model = build(name, device)
    built = time.perf_counter() - started
    use_bf16 = device.type == "cuda" and torch.cuda.is_bf16_supported()
    autocast = torch.autocast("cuda", dtype=torch.bfloat16) if use_bf16 else nullcontext()
    synchronize = torch.cuda.synchronize if device.type == "cuda" else (lambda: None)
    with torch.inference_mode(), autocast:
        if device.type == "cuda":
            model(images)  # warm-up (kernel selection)
            synchronize()
            torch.cuda.reset_peak_memory_stats(device)
        started = time.perf_counter()
        model(images)
        synchronize()
        seconds = time.perf_counter() - started
    peak = torch.cuda.max_memory_allocated(device) if device.type == "cuda" else peak_rss_bytes()
    parameters = sum(p.numel() for p in model.parameters())
    return {
        "model": name,
        "views": views,
        "device": device.type,
        "precision": "bf16 autocast" if use_bf16 else "float32",
        "size": f"{width}x{height}",
        "parameters": parameters,
        "build_s": built,
        "forward_s": seconds,
        "peak_bytes": peak,
        "peak_kind": "max_memory_allocated" if device.type == "cuda" else "peak RSS (VmHWM)",
    }


def run_child(name: str, views: int, device: str, timeout_s: float) -> dict[str, Any]:
    command = [sys.executable, "-m", "bench.pi3", "--child", name, str(views), device]
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s, env=os.environ.copy())
    if done.returncode != 0:
        return {
            "model": name,
            "views": views,
            "device": device,
            "error": done.stderr.strip().splitlines()[-1:],
        }
    return json.loads(done.stdout.strip().splitlines()[-1])


def table(rows: list[dict[str, Any]]) -> str:
    lines = [
        f"torch {torch.__version__}, {torch.get_num_threads()} CPU threads, random weights, "
        "one timed forward each",
        "",
        "| model | device | precision | input | views | parameters | forward s | peak memory GiB | measure |",
        "| --- | --- | --- | --- | ---: | ---: | ---: | ---: | --- |",
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['model']} | {r['device']} | | | {r['views']} | | failed: {r['error']} | | |")
            continue
        lines.append(
            f"| {r['model']} | {r['device']} | {r['precision']} | {r['size']} | {r['views']} "
            f"| {r['parameters'] / 1e9:.2f} B | {r['forward_s']:.1f} | {r['peak_bytes'] / GIB:.2f} "
            f"| {r['peak_kind']} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.pi3", description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, nargs="+", default=[4, 8])
    parser.add_argument("--models", nargs="+", default=["pi3x", "pi3", "vggt"], choices=sorted(SIZES))
    parser.add_argument("--devices", nargs="+", default=None, help="default: cpu, or cuda when present")
    parser.add_argument("--timeout", type=float, default=3600.0, help="seconds per child")
    parser.add_argument("--child", nargs=3, metavar=("MODEL", "VIEWS", "DEVICE"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.child[0], int(args.child[1]), args.child[2])))
        return
    devices = args.devices or (["cuda"] if torch.cuda.is_available() else ["cpu"])
    rows = []
    for device in devices:
        for views in sorted(args.views):
            for name in args.models:
                rows.append(run_child(name, views, device, args.timeout))
                print(f"# {rows[-1]}", file=sys.stderr, flush=True)
    print(table(rows))


if __name__ == "__main__":
    main()
