"""Determined camera-motion words of templeRing pairs with the focal withheld, against the truth.

Each pair (two photos 7.7 to ~46 degrees apart around the ring, also both turned 90 degrees as if
held sideways) is reconstructed by the classical backbone with no intrinsics. Two views cannot fix
the focal, so the pair is solved over field-of-view hypotheses; every determined word (turn side,
step direction, vertical step, tilt, roll; all in view 1's image axes) is compared with the words
the same rules give for the ground-truth cameras (turned the same way for the sideways photos). A
pair is "determined" when its turn or its step is determined; "wrong" when any determined word
differs from the truth.

    python -m bench templering_determinacy [--starts 1,5,9,13,17,21] [--steps 1,2,3,4,6]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from bench.templering import STEP_DEG, ring, subset
from bench.templering_data import load_cameras, load_image, realdata_dir, relative_pose
from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone, focal_hypotheses
from services.recon.scene_motion import pair_motion
from shared.geometry.camera_motion import CameraMotion
from shared.geometry.motion_determinacy import PairHypotheses, motion_over_focal

# Turning a photo 90 degrees clockwise: the camera turns about its optical axis.
SIDEWAYS = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def true_words(first: np.ndarray, second: np.ndarray) -> dict[str, str]:
    """The words of the true relative pose (unit step), by the same rules as the hypotheses."""
    rotation, translation = relative_pose(first, second)
    unit = translation / np.linalg.norm(translation)
    motion = motion_over_focal(PairHypotheses(0, 1, [0.0], [rotation.tolist()], [unit.tolist()], [0]))
    return {name: motion.quantities[name].words[0] for name in WORDS}


WORDS = ("turn", "direction", "vertical", "tilt", "roll")  # each read in view 1's image axes


def judge(recon, truth: dict[str, str]) -> tuple[str, str, dict[str, str]]:
    """("determined-right" | "determined-wrong" | "undetermined" | "unknown" | "refused", the
    sentence, and per word of WORDS "right", "wrong" or "undetermined"). The motion is what
    /v1/camera-motion says ("unknown": it describes no motion, e.g. a view at shallow angles)."""
    if recon.focal_hypotheses is None:
        return "refused", "; ".join(recon.warnings)[:200], {}
    motion = pair_motion(recon, (0, 1))
    if not isinstance(motion, CameraMotion) or motion.over_focal is None:
        return "unknown", motion.sentence, {}
    over = motion.over_focal
    quantities = over["quantities"]
    determined = {name: (quantities[name]["determined"], quantities[name]["words"][0]) for name in WORDS}
    words = {
        name: ("right" if word == truth[name] else "wrong") if flag else "undetermined"
        for name, (flag, word) in determined.items()
    }
    if not (over["turn_determined"] or over["direction_determined"]):
        return "undetermined", motion.sentence, words
    wrong = "wrong" in words.values()
    return ("determined-wrong" if wrong else "determined-right"), motion.sentence, words


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="pyspatial bench templering_determinacy", description=__doc__)
    parser.add_argument("--starts", default="1,5,9,13,17,21")
    parser.add_argument("--steps", default="1,2,3,4,6", help="ring steps of 7.7 degrees")
    parser.add_argument("--verbose", action="store_true")
    parser.add_argument(
        "--fov-grid",
        default=None,
        help="LOW,HIGH,STEP degrees instead of the backbone's 10,100,5 (sensitivity)",
    )
    args = parser.parse_args(argv)
    if args.fov_grid:
        low, high, step = (float(x) for x in args.fov_grid.split(","))
        focal_hypotheses.FOV_GRID_DEG = tuple(float(f) for f in np.arange(low, high + step / 2, step))
    root = realdata_dir()
    if root is None:
        raise SystemExit("templeRing not found (set PYSPATIAL_REALDATA_DIR)")
    cameras, azimuths = load_cameras(root), ring(root)
    backbone = ClassicalBackbone(densify=False)
    counts: dict[str, dict[str, int]] = {}
    tally: dict[tuple[str, str], int] = {}  # (word, right / wrong / undetermined) over placed pairs
    started = time.perf_counter()
    for sideways in (False, True):
        for step in (int(s) for s in args.steps.split(",")):
            for start in (int(s) for s in args.starts.split(",")):
                images = subset(azimuths, start, 2, step)
                if images is None:
                    continue
                pictures = [load_image(root, cameras[n - 1].name) for n in images]
                truth = [cameras[n - 1].extrinsic for n in images]
                if sideways:
                    pictures = [np.ascontiguousarray(np.rot90(p, -1)) for p in pictures]
                    truth = [np.concatenate([SIDEWAYS @ t[:, :3], SIDEWAYS @ t[:, 3:]], 1) for t in truth]
                try:
                    verdict, sentence, words = judge(backbone.reconstruct(pictures), true_words(*truth))
                except BackboneError as error:
                    verdict, sentence, words = "refused", str(error)[:200], {}
                for name, state in words.items():
                    tally[(name, state)] = tally.get((name, state), 0) + 1
                key = f"{step * STEP_DEG:.1f} deg{' sideways' if sideways else ''}"
                row = counts.setdefault(key, {})
                row[verdict] = row.get(verdict, 0) + 1
                if args.verbose:
                    print(f"{key} {images}: {verdict}: {sentence}  truth={true_words(*truth)}", flush=True)
    print("| pairs | determined & right | determined & wrong | undetermined | motion unknown | refused |")
    print("| --- | --- | --- | --- | --- | --- |")
    total: dict[str, int] = {}
    for key, row in counts.items():
        for name, value in row.items():
            total[name] = total.get(name, 0) + value
        print(_row(key, row))
    print(_row("all", total))
    print("\n| word (placed pairs) | determined & right | determined & wrong | undetermined |")
    print("| --- | --- | --- | --- |")
    for name in WORDS:
        states = [str(tally.get((name, state), 0)) for state in ("right", "wrong", "undetermined")]
        print(f"| {name} | " + " | ".join(states) + " |")
    print(f"{time.perf_counter() - started:.0f} s")


def _row(key: str, row: dict[str, int]) -> str:
    names = ("determined-right", "determined-wrong", "undetermined", "unknown", "refused")
    return f"| {key} | " + " | ".join(str(row.get(name, 0)) for name in names) + " |"


if __name__ == "__main__":
    main()
