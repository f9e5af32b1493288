"""Are the wrong pairs flagged? The classical backbone on templeRing with the true focal given.

    .venv/bin/python -m bench.pair_flags [--starts 13 16 24 28 36 8] [--sizes 2 3 4] [--scale 1.0]

The subsets of bench.templering (7.7, 23 and 46 degrees apart, and the ~69 and ~92 degree "wide"
ones), each reconstructed with the true intrinsics. --scale shrinks the photos first (and the
intrinsics with them): 0.25 leaves 160x120 images with a few dozen matches, the weak-texture case.
Per pair of registered views: its rotation error against the ground truth, and whether the
backbone set an `uncertain_reason` on it (PairConfidence) or on either of its views. The starts
of bench.templering's TUNING_STARTS are the tuning set; the others are held out (reported apart).
Prints markdown: pairs returned, pairs more than 5 degrees off, of those unflagged (must be 0),
and how many right pairs (within 2 degrees) carry a flag (the price of the flags).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import cv2
import numpy as np

from bench.templering import SPACINGS, TUNING_STARTS, WIDE, ring, subset
from bench.templering_data import load_cameras, load_image, pair_errors, realdata_dir
from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone


@dataclass
class Tally:
    subsets: int = 0
    refused: int = 0
    pairs: int = 0
    off: int = 0  # more than 5 degrees off
    off_unflagged: int = 0
    right_flagged: int = 0  # within 2 degrees yet flagged
    flagged: int = 0


def reconstruct(backbone: ClassicalBackbone, root, cameras, images: list[int], scale: float):
    pictures, intrinsics = [], []
    for number in images:
        picture = load_image(root, cameras[number - 1].name)
        intrinsic = cameras[number - 1].intrinsic.copy()
        if scale != 1.0:
            picture = cv2.resize(picture, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
            intrinsic[:2] *= scale
        pictures.append(picture)
        intrinsics.append(intrinsic)
    return backbone.reconstruct(pictures, intrinsics=intrinsics)


def tally_subset(tally: Tally, result, truth: np.ndarray, verbose: str | None) -> None:
    flags = {(p.first, p.second): p.uncertain_reason for p in result.pair_confidence}
    sigmas = {(p.first, p.second): p.rotation_uncertainty_deg for p in result.pair_confidence}
    views = [i for i, flag in enumerate(result.registered) if flag]
    keys = [(a, b) for position, a in enumerate(views) for b in views[position + 1 :]]
    for key, (error, _) in zip(keys, pair_errors(result.extrinsics, truth, result.registered), strict=True):
        view_flags = [result.view_confidence[v].uncertain_reason for v in key]
        flagged = bool(flags.get(key) or any(view_flags))
        tally.pairs += 1
        tally.flagged += flagged
        tally.off += error > 5.0
        tally.off_unflagged += error > 5.0 and not flagged
        tally.right_flagged += error <= 2.0 and flagged
        if verbose is not None:
            print(
                f"{verbose} pair {key}: {error:.1f} deg, sigma {sigmas.get(key, float('nan')):.2f}, "
                f"flag {flags.get(key) or view_flags}",
                flush=True,
            )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--starts", type=int, nargs="+", default=[13, 16, 24, 28, 36, 8])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2, 3, 4])
    parser.add_argument("--scale", type=float, default=1.0, help="shrink the photos by this factor")
    parser.add_argument("--verbose", action="store_true", help="print every pair")
    args = parser.parse_args(argv)
    root = realdata_dir()
    if root is None:
        raise SystemExit("templeRing not found: set PYSPATIAL_REALDATA_DIR (see bench/templering_data.py)")
    cameras, azimuths = load_cameras(root), ring(root)
    backbone = ClassicalBackbone()
    tallies = {"tuning": Tally(), "held-out": Tally()}
    plan = [(step, args.sizes) for step in SPACINGS.values()] + [(step, [2, 3]) for step in WIDE.values()]
    start_time = time.perf_counter()
    for step, sizes in plan:
        for count in sizes:
            for start in args.starts:
                images = subset(azimuths, start, count, step)
                if images is None:
                    continue
                tally = tallies["tuning" if start in TUNING_STARTS else "held-out"]
                tally.subsets += 1
                try:
                    result = reconstruct(backbone, root, cameras, images, args.scale)
                except BackboneError:
                    tally.refused += 1
                    continue
                truth = np.array([cameras[n - 1].extrinsic for n in images])
                tally_subset(tally, result, truth, str(images) if args.verbose else None)
    print(f"classical backbone, templeRing with the true focal, photos scaled by {args.scale}\n")
    print(
        "| starts | subsets | refused | pairs returned | > 5° off | > 5° off, unflagged | flagged "
        "| ≤ 2° yet flagged |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for group, t in tallies.items():
        print(
            f"| {group} | {t.subsets} | {t.refused} | {t.pairs} | {t.off} | {t.off_unflagged} | "
            f"{t.flagged} | {t.right_flagged} |"
        )
    print(f"\n{time.perf_counter() - start_time:.0f} s in all")


if __name__ == "__main__":
    main()
