"""Pose accuracy of the classical backbone on synthetic scenes with exact cameras.

    .venv/bin/python -m bench.classical_accuracy --scenes 8 --seed 0 [--size 640 480] [--focal none]

For each setting of shared/synthetic's rigs (rotation: turning in place, around: walking an arc,
among: four sides of an object), scenes are generated from consecutive seeds until N have a rig.
The rotation rig turns by --rotation-step degrees (the rig's own default, 90, leaves a 60-degree
camera no overlap between views). Per consecutive view pair: relative rotation error and
translation-direction error (pairs with a baseline only). A pair counts as registered when both
of its views are; an unregistered pair counts as a failure in the "under" shares. Prints markdown.

--focal exif (default): each render goes through a PNG with the camera's focal in EXIF, as a
camera writes it (shared/synthetic/photo.py), and the focal read back from it is given to the
backbone, as the recon service does. --focal none: no focal; the backbone self-calibrates or uses
its 60-degree prior (right for these renders), and refuses two views on the prior.
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import dataclass, field

import numpy as np

from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone
from shared.imaging.exif import camera_from_exif
from shared.synthetic import SETTINGS, default_intrinsic, generate_scene, make_rig, render_view, rotation_rig
from shared.synthetic.photo import photo_bytes


@dataclass
class SettingFigures:
    rotation_errors: list[float] = field(default_factory=list)  # registered pairs
    direction_errors: list[float] = field(default_factory=list)  # registered pairs with a baseline
    pairs: int = 0
    pairs_with_baseline: int = 0
    views: int = 0
    registered_views: int = 0
    seconds: list[float] = field(default_factory=list)
    failures: int = 0  # scenes where the backbone raised


def relative_pose(first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and translation of the second camera in the first camera's frame."""
    rotation = second[:, :3] @ first[:, :3].T
    return rotation, second[:, 3] - rotation @ first[:, 3]


def angle_between_rotations_deg(a: np.ndarray, b: np.ndarray) -> float:
    cosine = np.clip((np.trace(a @ b.T) - 1.0) / 2.0, -1.0, 1.0)
    return float(np.degrees(np.arccos(cosine)))


def angle_between_vectors_deg(a: np.ndarray, b: np.ndarray) -> float:
    norms = np.linalg.norm(a) * np.linalg.norm(b)
    if norms < 1e-12:
        return 180.0  # an estimate with no translation for a pair that has one is a full miss
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b) / norms, -1.0, 1.0))))


def evaluate_scene(
    backbone: ClassicalBackbone,
    images: list[np.ndarray],
    truth: np.ndarray,
    figures: SettingFigures,
    intrinsics: list[np.ndarray] | None = None,
) -> None:
    start = time.perf_counter()
    try:
        sources = None if intrinsics is None else ["exif"] * len(images)
        result = backbone.reconstruct(images, intrinsics=intrinsics, intrinsics_sources=sources)
    except BackboneError:
        figures.failures += 1
        registered = np.zeros(len(images), dtype=bool)
        estimated = np.full_like(truth, np.nan)
    else:
        registered, estimated = result.registered, result.extrinsics
    figures.seconds.append(time.perf_counter() - start)
    figures.views += len(images)
    figures.registered_views += int(registered.sum())
    for index in range(len(images) - 1):
        true_rotation, true_translation = relative_pose(truth[index], truth[index + 1])
        has_baseline = np.linalg.norm(true_translation) > 1e-6
        figures.pairs += 1
        figures.pairs_with_baseline += int(has_baseline)
        if not (registered[index] and registered[index + 1]):
            continue
        rotation, translation = relative_pose(estimated[index], estimated[index + 1])
        figures.rotation_errors.append(angle_between_rotations_deg(rotation, true_rotation))
        if has_baseline:
            figures.direction_errors.append(angle_between_vectors_deg(translation, true_translation))


def exif_focal(image: np.ndarray, intrinsic: np.ndarray) -> np.ndarray:
    """The intrinsics the recon service reads from the render saved as a camera saves it."""
    found, problem = camera_from_exif(photo_bytes(image, intrinsic))
    if found is None:
        raise RuntimeError(f"the render's EXIF focal did not read back: {problem}")
    return found.intrinsic


def share_under(errors: list[float], limit: float, total: int) -> str:
    if total == 0:
        return "-"
    return f"{sum(error < limit for error in errors) / total:.0%}"


def median_text(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}" if values else "-"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--scenes", type=int, default=8, help="scenes per setting")
    parser.add_argument("--seed", type=int, default=0, help="first scene seed")
    parser.add_argument("--size", type=int, nargs=2, default=(640, 480), metavar=("WIDTH", "HEIGHT"))
    parser.add_argument("--rotation-step", type=float, default=40.0, help="degrees per view, rotation rig")
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=SETTINGS)
    parser.add_argument("--focal", choices=("exif", "none"), default="exif", help="EXIF focal or none")
    args = parser.parse_args(argv)
    width, height = args.size
    intrinsic = default_intrinsic(width, height, 60.0)
    backbone = ClassicalBackbone()

    results: dict[str, SettingFigures] = {}
    for setting in args.settings:
        figures, seed = SettingFigures(), args.seed
        used = 0
        while used < args.scenes and seed < args.seed + 20 * args.scenes:
            scene = generate_scene(seed)
            rng = np.random.default_rng(seed)
            rig = (
                rotation_rig(scene, rng, 4, args.rotation_step)
                if setting == "rotation"
                else make_rig(setting, scene, rng)
            )
            seed += 1
            if rig is None:
                continue
            images = [
                render_view(scene, extrinsic, intrinsic, width, height).rgb for extrinsic in rig.extrinsics
            ]
            given = [exif_focal(image, intrinsic) for image in images] if args.focal == "exif" else None
            evaluate_scene(backbone, images, rig.extrinsics, figures, given)
            used += 1
        results[setting] = figures

    focal = "focal from EXIF" if args.focal == "exif" else "no focal given (prior: 60 deg)"
    print(f"classical backbone, {width}x{height} renders, true horizontal FOV 60 deg, {focal}\n")
    print(
        "| setting | scenes | pairs | median rot err (deg) | rot < 5 deg | median dir err (deg) "
        "| dir < 15 deg | views registered | raised | mean s / scene |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for setting, figures in results.items():
        scenes = len(figures.seconds)
        print(
            f"| {setting} | {scenes} | {figures.pairs} | {median_text(figures.rotation_errors)} "
            f"| {share_under(figures.rotation_errors, 5.0, figures.pairs)} "
            f"| {median_text(figures.direction_errors)} "
            f"| {share_under(figures.direction_errors, 15.0, figures.pairs_with_baseline)} "
            f"| {figures.registered_views}/{figures.views} | {figures.failures} "
            f"| {statistics.mean(figures.seconds) if scenes else float('nan'):.2f} |"
        )
    print(
        "\nErrors are over pairs whose views both registered; the '<' shares divide by all pairs "
        "(unregistered = failure). 'dir' covers pairs with a true baseline only."
    )


if __name__ == "__main__":
    main()
