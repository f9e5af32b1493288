"""Classical backbone against pycolmap's mapper on templeRing subsets: time and accuracy, one run.

    .venv/bin/python -m bench.templering_colmap [--starts 13 16 24 28 36 8] [--spacings 7.7 23]
        [--views 4] [--verbose]

Same subsets as bench.templering (N views `spacing` apart from each start). Per subset, the two
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
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.templering import SPACINGS, ring, subset, subset_inputs
from bench.templering_data import TempleView, load_cameras, pair_errors, realdata_dir
from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.colmap_import import pycolmap


@dataclass
class Run:
    seconds: float
    placed: int
    errors: list[tuple[float, float]]  # (rotation, direction) per registered pair

    def median_rotation(self) -> float:
        return statistics.median(e[0] for e in self.errors) if self.errors else float("nan")


def run_classical(
    backbone: ClassicalBackbone, cameras: list[TempleView], root: Path, images: list[int], given: bool
) -> Run:
    pictures, truth, intrinsics = subset_inputs(cameras, root, images, given)
    start = time.perf_counter()
    try:
        result = backbone.reconstruct(pictures, intrinsics=intrinsics)
    except BackboneError:
        return Run(time.perf_counter() - start, 0, [])
    seconds = time.perf_counter() - start
    if result.focal_hypotheses is not None:  # not a claimed pose (see bench.templering)
        return Run(seconds, 0, [])
    return Run(
        seconds, int(result.registered.sum()), pair_errors(result.extrinsics, truth, result.registered)
    )


def run_colmap(cameras: list[TempleView], root: Path, images: list[int], given: bool) -> Run:
    names = [cameras[number - 1].name for number in images]
    truth = np.array([cameras[number - 1].extrinsic for number in images])
    with tempfile.TemporaryDirectory(prefix="templering-colmap-") as folder:
        database = Path(folder) / "database.db"
        image_path = root / "templeRing"
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
            _set_true_cameras(database, cameras, images)
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


def _set_true_cameras(database: Path, cameras: list[TempleView], images: list[int]) -> None:
    db = pycolmap.Database.open(database)
    try:
        for image in db.read_all_images():
            number = int(image.name[len("templeR") : -len(".png")])
            intrinsic = cameras[number - 1].intrinsic
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


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--starts", type=int, nargs="+", default=[13, 16, 24, 28, 36, 8])
    parser.add_argument("--spacings", nargs="+", default=["7.7", "23"], choices=sorted(SPACINGS))
    parser.add_argument("--views", type=int, default=4)
    parser.add_argument("--verbose", action="store_true", help="print every run")
    args = parser.parse_args(argv)
    root = realdata_dir()
    if root is None:
        raise SystemExit("templeRing not found: set PYSPATIAL_REALDATA_DIR (see bench/templering_data.py)")
    pycolmap.logging.minloglevel = 2  # errors only: its per-image progress would bury the table
    cameras, azimuths = load_cameras(root), ring(root)
    backbone = ClassicalBackbone()
    plan = [
        images
        for label in args.spacings
        for start in args.starts
        if (images := subset(azimuths, start, args.views, SPACINGS[label])) is not None
    ]
    run_classical(backbone, cameras, root, plan[0], True)  # imports and thread pools, untimed
    runs: dict[tuple[str, bool], list[Run]] = {
        (s, g): [] for s in ("classical", "pycolmap") for g in (True, False)
    }
    for position, images in enumerate(plan):
        for given in (True, False):
            order = ("classical", "pycolmap") if position % 2 == 0 else ("pycolmap", "classical")
            for system in order:
                if system == "classical":
                    run = run_classical(backbone, cameras, root, images, given)
                else:
                    run = run_colmap(cameras, root, images, given)
                runs[(system, given)].append(run)
                if args.verbose:
                    print(
                        images,
                        system,
                        "true focal" if given else "no focal",
                        f"{run.seconds:.2f} s",
                        run.placed,
                        f"{run.median_rotation():.2f}",
                        flush=True,
                    )
    print(f"templeRing, {len(plan)} subsets of {args.views} views, spacings {' '.join(args.spacings)} deg\n")
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
            f"| {describe(ours, args.views)} | {describe(theirs, args.views)} |"
        )


if __name__ == "__main__":
    main()
