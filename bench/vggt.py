"""Forward time and peak memory of full-size VGGT-1B (random weights) for a few view counts.

    .venv/bin/python -m bench.vggt --views 2 4 8 --repeats 1

Weights are drawn with a fixed seed, so no checkpoint is needed; timings do not depend on the
values. Prints a markdown table: CPU always, CUDA too when a GPU is present (bf16 autocast where
supported, as the backbone runs).
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
import threading
import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from services.recon.backbones.vggt.config import VGGTConfig
from services.recon.backbones.vggt.model import VGGT

GIB = 1024**3


@dataclass
class Measurement:
    device: str
    precision: str
    views: int
    seconds: list[float]
    peak_bytes: int
    peak_kind: str


def random_vggt(config: VGGTConfig, device: torch.device, seed: int = 0) -> VGGT:
    """VGGT-1B with plausible random weights, allocated once (no default init pass)."""
    with torch.device("meta"):
        model = VGGT(config)
    return fill_random(model, device, seed)


def fill_random(model: torch.nn.Module, device: torch.device, seed: int = 0) -> Any:
    """Allocate a meta-device model on `device` with plausible random weights (fixed seed)."""
    model = model.to_empty(device=device)
    generator = torch.Generator(device=device).manual_seed(seed)
    with torch.no_grad():
        for name, parameter in model.named_parameters():
            if name.endswith(".gamma"):
                parameter.fill_(0.01)  # layer scale
            elif parameter.ndim == 1 and name.endswith(".weight"):
                parameter.fill_(1.0)  # layer norms
            elif parameter.ndim == 1:
                parameter.zero_()  # biases
            else:
                parameter.normal_(0.0, 0.02, generator=generator)
    return model.eval()


class RssSampler:
    """Peak resident memory of this process while active, sampled from /proc every few ms."""

    def __init__(self, interval_s: float = 0.005) -> None:
        self.interval_s = interval_s
        self.page_bytes = resource.getpagesize()
        self.peak = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def current(self) -> int:
        statm = Path("/proc/self/statm")
        if statm.exists():
            return int(statm.read_text().split()[1]) * self.page_bytes
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux-like fallback: KiB

    def _run(self) -> None:
        while not self._stop.is_set():
            self.peak = max(self.peak, self.current())
            time.sleep(self.interval_s)

    def __enter__(self) -> RssSampler:
        self.peak = self.current()
        self._thread.start()
        return self

    def __exit__(self, *_: Any) -> None:
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, self.current())


def time_forward(
    model: VGGT, images: torch.Tensor, repeats: int, warmup: int, autocast: Callable[[], Any]
) -> list[float]:
    synchronize = torch.cuda.synchronize if images.device.type == "cuda" else (lambda: None)
    seconds = []
    with torch.inference_mode():
        for run in range(warmup + repeats):
            synchronize()
            start = time.perf_counter()
            with autocast():
                model(images)
            synchronize()
            if run >= warmup:
                seconds.append(time.perf_counter() - start)
    return seconds


def measure_device(
    device: torch.device, views: list[int], repeats: int, warmup: int, size: int
) -> list[Measurement]:
    config = VGGTConfig()
    model = random_vggt(config, device)
    use_bf16 = device.type == "cuda" and torch.cuda.is_bf16_supported()
    precision = "bf16 autocast" if use_bf16 else "float32"

    def autocast() -> Any:
        return torch.autocast("cuda", dtype=torch.bfloat16) if use_bf16 else nullcontext()

    generator = torch.Generator().manual_seed(1)
    results = []
    for count in views:
        images = torch.rand(count, 3, size, size, generator=generator).to(device)
        if device.type == "cuda":
            torch.cuda.empty_cache()
            torch.cuda.reset_peak_memory_stats(device)
            seconds = time_forward(model, images, repeats, warmup, autocast)
            peak, kind = torch.cuda.max_memory_allocated(device), "max_memory_allocated"
        else:
            with RssSampler() as sampler:
                seconds = time_forward(model, images, repeats, warmup, autocast)
            peak, kind = sampler.peak, "process RSS"
        results.append(Measurement(device.type, precision, count, seconds, peak, kind))
        print(f"# {device.type} {count} views: {', '.join(f'{s:.2f}' for s in seconds)} s", file=sys.stderr)
    return results


def markdown_table(results: list[Measurement], size: int) -> str:
    lines = [
        f"VGGT-1B forward (aggregator + camera, depth and point heads), {size}x{size} images, "
        f"torch {torch.__version__}, {torch.get_num_threads()} CPU threads",
        "",
        "| device | precision | views | runs | mean s | min s | peak memory GiB | memory measure |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    for r in results:
        lines.append(
            f"| {r.device} | {r.precision} | {r.views} | {len(r.seconds)} | {statistics.mean(r.seconds):.2f} "
            f"| {min(r.seconds):.2f} | {r.peak_bytes / GIB:.2f} | {r.peak_kind} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.vggt", description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, nargs="+", default=[2, 4, 8], help="view counts to time")
    parser.add_argument("--repeats", type=int, default=1, help="timed runs per view count")
    parser.add_argument(
        "--warmup", type=int, default=None, help="untimed runs first (default: 0 CPU, 1 CUDA)"
    )
    parser.add_argument("--size", type=int, default=518, help="square image side, a multiple of 14")
    parser.add_argument("--devices", nargs="+", default=None, help="default: cpu, plus cuda when present")
    args = parser.parse_args(argv)
    if args.size % 14 or args.repeats < 1 or min(args.views) < 1:
        parser.error("size must be a multiple of 14, repeats and views at least 1")
    devices = args.devices or (["cpu", "cuda"] if torch.cuda.is_available() else ["cpu"])
    results = []
    for name in devices:
        device = torch.device(name)
        warmup = args.warmup if args.warmup is not None else (1 if device.type == "cuda" else 0)
        results += measure_device(device, sorted(args.views), args.repeats, warmup, args.size)
    print(markdown_table(results, args.size))


if __name__ == "__main__":
    main()
