"""Classical backbone on real photographs: Middlebury templeRing, with and without the true focal.

    .venv/bin/python -m bench.templering [--starts 13 16 24 28 36 8] [--sizes 2 3 4 6]

Subsets: N views whose capture azimuths are `spacing` apart (7.7, 23 and 46 degrees, plus ~69
and ~92 degree "wide" subsets that must be registered correctly or refused), starting at each
given image (at 46 degrees, 6 views exist only from image 16); a view is the image nearest
each target azimuth (within 2 degrees, either pass of the ring; the ring has gaps).
Start 13 (and 1, 3, 6, 20, 33, looked at while developing) is the tuning set; the other starts
are held out and reported separately.

Per subset: the median over pairs of registered views of the relative rotation error and of the
translation-direction error. A subset "registers" when at least two of its views do. Columns:
no focal given (self-calibration) | the true intrinsics given ("uploaded"), same subsets, one run.
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bench.templering_data import TempleView, load_cameras, load_image, pair_errors, realdata_dir
from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone

STEP_DEG = 360.0 / 47  # the ring's angular step (the README's 7.7 degrees)
TUNING_STARTS = (1, 3, 6, 13, 20, 33)
SPACINGS = {"7.7": 1, "23": 3, "46": 6}
WIDE = {"69": 9, "92": 12}
MATCH_TOLERANCE_DEG = 2.0


def ring(root: Path) -> dict[int, float]:
    """Image number -> capture azimuth (degrees)."""
    azimuths = {}
    for line in (root / "templeRing" / "templeR_ang.txt").read_text().split("\n"):
        fields = line.split()
        if len(fields) == 3:
            azimuths[int(fields[2][len("templeR") : -len(".png")])] = float(fields[1])
    return azimuths


def subset(azimuths: dict[int, float], start: int, count: int, step: int) -> list[int] | None:
    chosen = [start]
    for index in range(1, count):
        target = azimuths[start] + index * step * STEP_DEG
        best = min(azimuths, key=lambda image: abs((azimuths[image] - target + 180) % 360 - 180))
        if abs((azimuths[best] - target + 180) % 360 - 180) > MATCH_TOLERANCE_DEG or best in chosen:
            return None
        chosen.append(best)
    return chosen


@dataclass
class Outcome:
    registered: int  # views
    rotation: float = float("nan")  # per-subset medians
    direction: float = float("nan")
    worst_rotation: float = float("nan")
    seconds: float = 0.0
    refusal: str = ""
    focal_source: str = ""  # intrinsics_source of the registered views


@dataclass
class Row:
    outcomes: dict[str, list[Outcome]] = field(default_factory=lambda: {"none": [], "true": []})


def subset_inputs(
    cameras: list[TempleView], root: Path, images: list[int], given: bool
) -> tuple[list[np.ndarray], np.ndarray, list[np.ndarray] | None]:
    """A subset's photos (1-based numbers), true extrinsics, and its true intrinsics when given."""
    pictures = [load_image(root, cameras[number - 1].name) for number in images]
    truth = np.array([cameras[number - 1].extrinsic for number in images])
    intrinsics = [cameras[number - 1].intrinsic for number in images] if given else None
    return pictures, truth, intrinsics


def run_subset(
    backbone: ClassicalBackbone, cameras: list[TempleView], root: Path, images: list[int], given: bool
) -> Outcome:
    pictures, truth, intrinsics = subset_inputs(cameras, root, images, given)
    start = time.perf_counter()
    try:
        result = backbone.reconstruct(pictures, intrinsics=intrinsics)
    except BackboneError as error:
        return Outcome(0, seconds=time.perf_counter() - start, refusal=str(error))
    seconds = time.perf_counter() - start
    if result.focal_hypotheses is not None:
        # Solved over focal hypotheses: the poses are one hypothesis, flagged, not a claimed pose
        # (bench.templering_determinacy measures what they determine).
        return Outcome(0, seconds=seconds, refusal="over focal hypotheses", focal_source="hypotheses")
    errors = pair_errors(result.extrinsics, truth, result.registered)
    registered = int(result.registered.sum())
    placed = [i for i, flag in enumerate(result.registered) if flag]
    source = ",".join(sorted({str(result.intrinsics_source[i]) for i in placed}))
    if not errors:
        return Outcome(registered, seconds=seconds, focal_source=source)
    return Outcome(
        registered,
        statistics.median(e[0] for e in errors),
        statistics.median(e[1] for e in errors),
        max(e[0] for e in errors),
        seconds,
        focal_source=source,
    )


def summary(outcomes: list[Outcome], wide: bool) -> str:
    placed = [o for o in outcomes if o.registered >= 2]
    if not outcomes:
        return "- | - | - | -"
    if wide:  # every pair within 5 degrees, or refused
        wrong = sum(o.worst_rotation > 5.0 for o in placed)
    else:
        wrong = sum(o.rotation > 2.0 or o.direction > 3.0 for o in placed)
    rotation = max((o.rotation for o in placed), default=float("nan"))
    direction = max((o.direction for o in placed), default=float("nan"))
    return f"{len(placed)}/{len(outcomes)} | {rotation:.2f} | {direction:.2f} | {wrong}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--starts", type=int, nargs="+", default=[13, 16, 24, 28, 36, 8])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2, 3, 4, 6])
    parser.add_argument("--verbose", action="store_true", help="print every subset")
    args = parser.parse_args(argv)
    root = realdata_dir()
    if root is None:
        raise SystemExit("templeRing not found: set PYSPATIAL_REALDATA_DIR (see bench/templering_data.py)")
    cameras, azimuths = load_cameras(root), ring(root)
    backbone = ClassicalBackbone()
    rows: dict[tuple[str, int, str, bool], Row] = {}
    four_view_seconds: list[float] = []
    plan = [(label, step, False) for label, step in SPACINGS.items()]
    plan += [(label, step, True) for label, step in WIDE.items()]
    for label, step, wide in plan:
        for count in args.sizes if not wide else [2, 3]:
            for start in args.starts:
                images = subset(azimuths, start, count, step)
                if images is None:
                    continue
                group = "tuning" if start in TUNING_STARTS else "held-out"
                row = rows.setdefault((label, count, group, wide), Row())
                for given, key in ((False, "none"), (True, "true")):
                    outcome = run_subset(backbone, cameras, root, images, given)
                    row.outcomes[key].append(outcome)
                    if count == 4 and not given:
                        four_view_seconds.append(outcome.seconds)
                    if args.verbose:
                        print(images, key, outcome, flush=True)
    print("classical backbone on templeRing (640x480, true horizontal FOV 23.8 deg)\n")
    print(
        "| spacing (°) | views | starts | registered, no focal | worst median rot (°) | worst median dir (°) "
        "| wrong | registered, true focal | worst median rot (°) | worst median dir (°) | wrong |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for (label, count, group, wide), row in rows.items():
        print(
            f"| {label}{' (wide)' if wide else ''} | {count} | {group} "
            f"| {summary(row.outcomes['none'], wide)} | {summary(row.outcomes['true'], wide)} |"
        )
    if four_view_seconds:
        print(
            f"\n4 views, no focal, cold: median {statistics.median(four_view_seconds):.2f} s, "
            f"max {max(four_view_seconds):.2f} s over {len(four_view_seconds)} scenes"
        )
    print(
        "\n'registered' = subsets where at least two views registered / subsets. 'wrong' = registered "
        "subsets with median rotation error > 2° or median direction error > 3° (wide: any pair > 5°)."
    )


if __name__ == "__main__":
    main()
