"""Classical backbone against pycolmap's mapper on a ring's subsets: time and accuracy, one run.

    .venv/bin/python -m bench.templering_colmap [--ring FOLDER] [--starts 13 16 24 28 36 8]
        [--spacings 7.7 23] [--views 4] [--verbose]

--ring: any folder in the Middlebury format (bench/ring_data.py), templeRing by default; a
synthetic one comes from `python -m shared.synthetic.weak_texture_ring OUT --seed N`. Same
subsets as bench.templering (N views `spacing` ring steps apart from each start; on another ring
the spacing labels name the same number of steps; --starts defaults to six starts spread around
the ring). Per subset, the two
systems run back to back in this process, with the true intrinsics given and without, in
alternating order from one subset to the next (so neither always runs first, on a warmer cache).

- classical: `ClassicalBackbone().reconstruct(images, intrinsics=...)` on decoded images (the
  four PNG decodes, ~4 ms each, are outside its clock).
- pycolmap: SIFT extraction from the PNG files, exhaustive matching with geometric verification,
  incremental mapping, in a fresh database. True focal: one PINHOLE camera per image with the
  true K, which the mapper keeps fixed. No focal: one shared SIMPLE_RADIAL camera with COLMAP's
  prior, refined by its bundle adjustment (its default).

Both use every CPU core they are given (OpenCV's and COLMAP's thread pools, defaults). The time
ratio is classical / pycolmap: the sum over subsets, and the median of per-subset ratios. Accuracy:
views placed, and the median over registered pairs of the rotation error (and the worst).
Error bars (classical, true focal): per registered pair its rotation error over the stated
`rotation_uncertainty_deg`: the share within 2 sigma, the worst ratio, and the pairs more than 5
degrees off that carry no `uncertain_reason`.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bench.ring_data import Ring, load_ring, ring_subset
from bench.templering import SPACINGS
from bench.templering_data import pair_errors, realdata_dir
from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.colmap_import import pycolmap


@dataclass
class Run:
    seconds: float
    placed: int
    errors: list[tuple[float, float]]  # (rotation, direction) per registered pair
    stated: list[tuple[float, bool]] = field(default_factory=list)  # (rotation sigma, flagged) per pair

    def median_rotation(self) -> float:
        return statistics.median(e[0] for e in self.errors) if self.errors else float("nan")


def run_classical(backbone: ClassicalBackbone, ring: Ring, images: list[int], given: bool) -> Run:
    pictures = [ring.image(number) for number in images]
    truth = np.array([ring.views[number - 1].extrinsic for number in images])
    intrinsics = [ring.views[number - 1].intrinsic for number in images] if given else None
    start = time.perf_counter()
    try:
        result = backbone.reconstruct(pictures, intrinsics=intrinsics)
    except BackboneError:
        return Run(time.perf_counter() - start, 0, [])
    seconds = time.perf_counter() - start
    if result.focal_hypotheses is not None:  # not a claimed pose (see bench.templering)
        return Run(seconds, 0, [])
    return Run(
        seconds,
        int(result.registered.sum()),
        pair_errors(result.extrinsics, truth, result.registered),
        stated_uncertainty(result),
    )


def stated_uncertainty(result) -> list[tuple[float, bool]]:
    """Per registered pair, in pair_errors' order: the stated rotation sigma, and whether the pair
    or either of its views carries an uncertain_reason."""
    pairs = {(p.first, p.second): p for p in result.pair_confidence}
    views = [index for index, flag in enumerate(result.registered) if flag]
    stated = []
    for position, first in enumerate(views):
        for second in views[position + 1 :]:
            pair = pairs.get((first, second))
            view_flags = [result.view_confidence[v].uncertain_reason for v in (first, second)]
            sigma = pair.rotation_uncertainty_deg if pair is not None else float("nan")
            stated.append((sigma, bool((pair is not None and pair.uncertain_reason) or any(view_flags))))
    return stated


def run_colmap(ring: Ring, images: list[int], given: bool) -> Run:
    names = [ring.views[number - 1].name for number in images]
    truth = np.array([ring.views[number - 1].extrinsic for number in images])
    with tempfile.TemporaryDirectory(prefix="ring-colmap-") as folder:
        database = Path(folder) / "database.db"
        image_path = ring.folder
        start = time.perf_counter()
        reader = pycolmap.ImageReaderOptions()
        if given:
            reader.camera_model = "PINHOLE"
            mode = pycolmap.CameraMode.PER_IMAGE
        else:
            reader.camera_model = "SIMPLE_RADIAL"
            mode = pycolmap.CameraMode.SINGLE
        pycolmap.extract_features(
            database,
            image_path,
            image_names=names,
            camera_mode=mode,
            reader_options=reader,
            device=pycolmap.Device.cpu,
        )
        if given:
            _set_true_cameras(database, ring)
        pycolmap.match_exhaustive(database, device=pycolmap.Device.cpu)
        options = pycolmap.IncrementalPipelineOptions()
        if given:
            options.ba_refine_focal_length = False
            options.ba_refine_principal_point = False
            options.ba_refine_extra_params = False
        models = pycolmap.incremental_mapping(database, image_path, Path(folder), options=options)
        seconds = time.perf_counter() - start
    if not models:
        return Run(seconds, 0, [])
    model = max(models.values(), key=lambda m: m.num_reg_images())
    extrinsics = np.full((len(images), 3, 4), np.nan)
    registered = np.zeros(len(images), bool)
    for image in model.images.values():
        if image.has_pose:
            index = names.index(image.name)
            extrinsics[index] = np.asarray(image.cam_from_world().matrix())
            registered[index] = True
    return Run(seconds, int(registered.sum()), pair_errors(extrinsics, truth, registered))


def _set_true_cameras(database: Path, ring: Ring) -> None:
    by_name = {view.name: view for view in ring.views}
    db = pycolmap.Database.open(database)
    try:
        for image in db.read_all_images():
            intrinsic = by_name[image.name].intrinsic
            camera = db.read_camera(image.camera_id)
            camera.params = [intrinsic[0, 0], intrinsic[1, 1], intrinsic[0, 2], intrinsic[1, 2]]
            camera.has_prior_focal_length = True
            db.update_camera(camera)
    finally:
        db.close()


def describe(runs: list[Run], views: int) -> str:
    placed = sum(run.placed for run in runs)
    medians = [run.median_rotation() for run in runs if run.errors]
    worst = max((e[0] for run in runs for e in run.errors), default=float("nan"))
    median = statistics.median(medians) if medians else float("nan")
    return f"{placed}/{views * len(runs)} | {median:.2f} | {worst:.2f}"


def calibration(runs: list[Run]) -> str:
    """Error bars against the truth: error / stated sigma per pair with a finite sigma."""
    pairs = [
        (e[0], sigma, flagged)
        for run in runs
        for e, (sigma, flagged) in zip(run.errors, run.stated, strict=True)
    ]
    ratios = [error / sigma for error, sigma, _ in pairs if np.isfinite(sigma) and sigma > 0]
    no_sigma = len(pairs) - len(ratios)
    within = sum(ratio <= 2.0 for ratio in ratios)
    over_three = sum(ratio > 3.0 for ratio in ratios)
    off_unflagged = sum(error > 5.0 and not flagged for error, _, flagged in pairs)
    share = f"{within}/{len(ratios)} ({100 * within / len(ratios):.0f}%)" if ratios else "-"
    worst = f"{max(ratios):.2f}" if ratios else "-"
    return f"| {len(pairs)} | {no_sigma} | {share} | {worst} | {over_three} | {off_unflagged} |"


def default_starts(ring: Ring) -> list[int]:
    if ring.name == "templeRing":
        return [13, 16, 24, 28, 36, 8]  # bench.templering's
    return [1 + round(k * len(ring.views) / 6) for k in range(6)]


def plan_subsets(ring: Ring, starts: list[int], spacings: list[str], views: int) -> list[list[int]]:
    return [
        images
        for label in spacings
        for start in starts
        if (images := ring_subset(ring, start, views, SPACINGS[label])) is not None
    ]


def run_all(
    ring: Ring, plan: list[list[int]], classical_only: bool, verbose: bool
) -> dict[tuple[str, bool], list[Run]]:
    backbone = ClassicalBackbone()
    run_classical(backbone, ring, plan[0], True)  # imports and thread pools, untimed
    systems = ("classical",) if classical_only else ("classical", "pycolmap")
    runs: dict[tuple[str, bool], list[Run]] = {(s, g): [] for s in systems for g in (True, False)}
    for position, images in enumerate(plan):
        for given in (True, False):
            for system in systems if position % 2 == 0 else systems[::-1]:
                if system == "classical":
                    run = run_classical(backbone, ring, images, given)
                else:
                    run = run_colmap(ring, images, given)
                runs[(system, given)].append(run)
                if verbose:
                    focal = "true focal" if given else "no focal"
                    rotations = " ".join(f"{e[0]:.2f}" for e in run.errors)
                    sigmas = " ".join(f"{sigma:.2f}{'F' if flagged else ''}" for sigma, flagged in run.stated)
                    print(images, system, focal, f"{run.seconds:.2f} s", run.placed, rotations, "|", sigmas)
    return runs


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--ring", type=Path, help="a Middlebury-format folder (default: templeRing)")
    parser.add_argument("--starts", type=int, nargs="+")
    parser.add_argument("--spacings", nargs="+", default=["7.7", "23"], choices=sorted(SPACINGS))
    parser.add_argument("--views", type=int, default=4)
    parser.add_argument("--classical-only", action="store_true", help="no pycolmap runs (error bars only)")
    parser.add_argument("--verbose", action="store_true", help="print every run")
    args = parser.parse_args(argv)
    folder = args.ring
    if folder is None:
        root = realdata_dir()
        if root is None:
            raise SystemExit(
                "templeRing not found: set PYSPATIAL_REALDATA_DIR (see bench/templering_data.py)"
            )
        folder = root / "templeRing"
    pycolmap.logging.minloglevel = 2  # errors only: its per-image progress would bury the table
    ring = load_ring(folder)
    plan = plan_subsets(ring, args.starts or default_starts(ring), args.spacings, args.views)
    runs = run_all(ring, plan, args.classical_only, args.verbose)
    print(f"{ring.name}, {len(plan)} subsets of {args.views} views, spacings {' '.join(args.spacings)}\n")
    if not args.classical_only:
        print_comparison(runs, args.views)
    print("\nError bars, classical, true focal (pairs with truth; ratio = rotation error / stated sigma):\n")
    print("| pairs | no sigma | within 2 sigma | worst ratio | over 3 sigma | > 5° off, unflagged |")
    print("| --- | --- | --- | --- | --- | --- |")
    print(calibration(runs[("classical", True)]))


def print_comparison(runs: dict[tuple[str, bool], list[Run]], views: int) -> None:
    print(
        "| focal | classical s (sum) | pycolmap s (sum) | ratio (sum) | ratio (median) "
        "| classical placed / median rot / worst | pycolmap placed / median rot / worst |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for given in (True, False):
        ours, theirs = runs[("classical", given)], runs[("pycolmap", given)]
        total_ours, total_theirs = sum(r.seconds for r in ours), sum(r.seconds for r in theirs)
        ratios = [a.seconds / b.seconds for a, b in zip(ours, theirs, strict=True)]
        print(
            f"| {'true' if given else 'none'} | {total_ours:.2f} | {total_theirs:.2f} "
            f"| {total_ours / total_theirs:.2f} | {statistics.median(ratios):.2f} "
            f"| {describe(ours, views)} | {describe(theirs, views)} |"
        )


if __name__ == "__main__":
    main()
