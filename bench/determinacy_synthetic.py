"""Answered / right / refused on a synthetic MindCube-style set with no focal given (no EXIF).

    python -m bench determinacy_synthetic --scenes 12 --seed 0

Scenes from shared/synthetic in the around / among / rotation settings (2-4 views, wide
baselines), their motion and turn questions in MindCube's wording with exact answers. The photos
go to the classical backbone as bare pixels, so the focal is unknown: scenes whose views cannot
fix it are solved over field-of-view hypotheses. Each question is answered by the agent's offline
answerer from the camera-motion sentence the recon service would give for its pair (same
functions, in process): a choice is answered only when it holds at every hypothesis. A refusal
"states the range" when its reason carries the sentence of what the hypotheses allow.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

import numpy as np

from services.agent.answering import UNDETERMINED, answer_offline
from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone, focal_hypotheses
from services.recon.scene_motion import pair_motion
from shared.geometry.camera_motion import CameraMotion
from shared.questions.intent import parse_question
from shared.synthetic.cameras import SETTINGS
from shared.synthetic.dataset import _scene_and_rig
from shared.synthetic.questions import questions_for_rig
from shared.synthetic.render import default_intrinsic, render_view

FAMILIES = ("motion", "turn")  # what the offline answerer reads from a motion sentence


def pair_sentence(recon, pair: tuple[int, int]) -> tuple[str, bool]:
    """The service's sentence for one pair, and whether it was solved over focal hypotheses."""
    motion = pair_motion(recon, pair)
    return motion.sentence, isinstance(motion, CameraMotion) and motion.over_focal is not None


def run_scene(backbone: ClassicalBackbone, seed: int, index: int, size: tuple[int, int]) -> list[dict]:
    setting = SETTINGS[index % len(SETTINGS)]
    scene, rig, _ = _scene_and_rig(seed, index, setting)
    intrinsic = default_intrinsic(*size)
    images = [render_view(scene, extrinsic, intrinsic, *size).rgb for extrinsic in rig.extrinsics]
    questions = [
        q for q in questions_for_rig(scene, rig, np.random.default_rng([seed, index])) if q.family in FAMILIES
    ]
    try:
        recon = backbone.reconstruct(images)
    except BackboneError as error:
        return [
            {"setting": setting, "verdict": "refused", "hypotheses": False, "why": str(error)}
            for _ in questions
        ]
    rows = []
    for question in questions:
        intent = parse_question(question.text, len(images))
        sentence, over_focal = pair_sentence(recon, tuple(question.facts["pair"]))
        result = answer_offline(intent, sentence, [])
        if result.answer is None:
            verdict = "refused"
        else:
            verdict = "right" if result.answer == question.answer_letter else "wrong"
        rows.append(
            {
                "setting": setting,
                "views": len(images),
                "verdict": verdict,
                "hypotheses": over_focal,
                "states_range": UNDETERMINED in (result.reason or ""),
                "why": result.reason or result.reasoning,
            }
        )
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="pyspatial bench determinacy_synthetic", description=__doc__)
    parser.add_argument("--scenes", type=int, default=12)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
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
    backbone = ClassicalBackbone(densify=False)
    started = time.perf_counter()
    rows: list[dict] = []
    for index in range(args.scenes):
        scene_rows = run_scene(backbone, args.seed, index, (args.width, args.height))
        rows.extend(scene_rows)
        if args.verbose:
            for row in scene_rows:
                print(index, row, flush=True)
    head = ("setting", "questions", "over focal", "answered", "right", "wrong", "refused", "with range")
    print("| " + " | ".join(head) + " |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for setting in (*SETTINGS, "all"):
        chosen = [row for row in rows if setting in ("all", row["setting"])]
        counts = Counter(row["verdict"] for row in chosen)
        hypotheses = sum(row["hypotheses"] for row in chosen)
        stating = sum(row.get("states_range", False) for row in chosen if row["verdict"] == "refused")
        answered = counts["right"] + counts["wrong"]
        numbers = (len(chosen), hypotheses, answered, counts["right"], counts["wrong"])
        numbers += (counts["refused"], stating)
        print(f"| {setting} | " + " | ".join(str(n) for n in numbers) + " |")
    print(f"{time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
