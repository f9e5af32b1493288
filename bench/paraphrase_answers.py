"""The paraphrase corpus asked of the offline system on scenes of known motion: answered, right, wrong.

    python -m bench paraphrase_answers --source synthetic [--scenes 26] [--seed 0]
    python -m bench paraphrase_answers --source templering [--starts 1,5,9,13,17,21] [--steps 1,2,3,4,6]

Recon and agent services are started with no language model (the offline planner and answerer)
and every question goes through POST /v1/solve, worded once with the tuning lists and once with
the held-out ones (tests/support/paraphrases.py), reported apart.

- synthetic: MMSI-style rooms (shared/synthetic/mmsi.py) with exact cameras and depth (posed-rgbd):
  2-4 views, view B = view A moved or turned one way on purpose (a step, a turn, a tilt, a roll, or
  none), the others elsewhere in the room; asked as translation, position, rotation or mixed
  options, with the pair in either order.
- templering: the templeRing determinacy pairs (bench/templering_determinacy.py's set, as taken and
  turned 90 degrees), reconstructed by the classical backbone with no focal; every option's truth
  from the calibrated cameras (bench/templering_questions.py); asked in both orders.

Each scene also gets questions that must abstain (a pair that cannot be read, an option that says
two things, a stem whose quantity no option states). Per split: questions, answered, right, wrong,
abstained (with the reasons, counted), answers given although the pair was misread (the reading of
shared/questions/reading.py against the corpus's expected pair), and of the must-abstain questions
how many were refused.
"""

from __future__ import annotations

import argparse
import random
import re
import tempfile
import time
import uuid
from collections import Counter
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from shared.local.services import running_service
from shared.questions.reading import read_question
from shared.wire.client import AgentClient, ReconClient, ServiceError
from tests.support.paraphrases import (
    ROTATIONS,
    SPLITS,
    STILL,
    TRANSLATIONS,
    AskSpec,
    ClaimSpec,
    ParaphraseItem,
    load_wordings,
    phrase,
    quantity_of,
)

OFFLINE_ENV = {"PYSPATIAL_CODE_MODEL": "", "PYSPATIAL_ANSWER_MODEL": ""}
MOTION_CLAIMS = {  # shared/synthetic/mmsi.py's motions as the claim each makes true
    "right": ClaimSpec("translation", ("right",)),
    "left": ClaimSpec("translation", ("left",)),
    "up": ClaimSpec("translation", ("up",)),
    "down": ClaimSpec("translation", ("down",)),
    "forward": ClaimSpec("translation", ("forward",)),
    "backward": ClaimSpec("translation", ("backward",)),
    "turn left": ClaimSpec("rotation", axis="yaw", sense="left"),
    "turn right": ClaimSpec("rotation", axis="yaw", sense="right"),
    "tilt up": ClaimSpec("rotation", axis="pitch", sense="up"),
    "tilt down": ClaimSpec("rotation", axis="pitch", sense="down"),
    "roll clockwise": ClaimSpec("rotation", axis="roll", sense="clockwise"),
    "roll counterclockwise": ClaimSpec("rotation", axis="roll", sense="counterclockwise"),
    "still": STILL,
}
REASON_WORDS = {  # what a reason names, to count abstentions by kind
    "pair": r"\bpair\b|\bviews?\b|\bimages?\b|which two",
    "option": r"\boption",
    "quantity": r"quantit|\bstem\b|\basks?\b",
}


@dataclass
class AskedScene:
    label: str
    setting: str
    images: list[np.ndarray]
    specs: list[AskSpec]
    exact: dict | None = None  # depths, extrinsics, intrinsics for posed-rgbd
    scene_id: str | None = None


@dataclass
class Tally:
    counts: Counter = field(default_factory=Counter)
    reasons: Counter = field(default_factory=Counter)


def _options(
    truth: ClaimSpec, false: list[ClaimSpec], rng: random.Random
) -> tuple[tuple[ClaimSpec, ...], int]:
    claims = [truth, *rng.sample(false, 3)]
    rng.shuffle(claims)
    return tuple(claims), claims.index(truth)


def synthetic_specs(motion: str, count: int, pair: tuple[int, int], rng: random.Random) -> list[AskSpec]:
    """Questions a motion answers: its quantity (and a position / mixed one), plus one that must abstain."""
    truth = MOTION_CLAIMS[motion]
    specs = []
    if truth.kind == "translation":
        others = [c for c in TRANSLATIONS if c != truth]
        asked = [
            _options(truth, [*others, STILL], rng),
            _options(ClaimSpec("position", truth.ways), [ClaimSpec("position", c.ways) for c in others], rng),
            _options(truth, [*rng.sample(others, 1), *ROTATIONS], rng),
        ]
    elif truth.kind == "rotation":
        others = [c for c in ROTATIONS if c != truth]
        asked = [
            _options(truth, [*others, STILL], rng),
            _options(truth, [*rng.sample(others, 1), *TRANSLATIONS], rng),
        ]
    else:
        asked = [_options(STILL, list(TRANSLATIONS), rng), _options(STILL, list(ROTATIONS), rng)]
    for claims, index in asked:
        specs.append(AskSpec(count, pair, quantity_of(claims), claims, index))
    return [*specs, _abstaining(specs[0], count, pair, rng)]


def _abstaining(spec: AskSpec, count: int, pair: tuple[int, int], rng: random.Random) -> AskSpec:
    kinds = (
        ["option"] + (["pair"] if count >= 3 else []) + (["quantity"] if spec.quantity != "position" else [])
    )
    kind = rng.choice(kinds)
    third = next((v for v in range(1, count + 1) if v not in pair), None) if kind == "pair" else None
    quantity = spec.quantity if spec.quantity in ("translation", "rotation") else "translation"
    if kind == "quantity" and spec.quantity not in ("translation", "rotation"):
        claims, index = _options(TRANSLATIONS[0], list(TRANSLATIONS[1:]), rng)
        return AskSpec(count, pair, "translation", claims, index, "quantity")
    if kind == "quantity":
        return AskSpec(count, pair, quantity, spec.claims, spec.truth, "quantity")
    return AskSpec(count, pair, spec.quantity, spec.claims, spec.truth, kind, third)


STEP_SCALE = 2.5  # MMSI's synthetic steps (0.3-0.4 m) times this: clear of the still threshold here
OTHER_VIEWS = ("turn left", "turn right", "tilt up")  # the views not asked: at A's centre, turned


def _moved(first: np.ndarray, motion: str) -> np.ndarray:
    """Camera B: camera A moved as shared/synthetic/mmsi.py's `motion` says, its step STEP_SCALE longer."""
    from shared.synthetic.mmsi import moved_camera

    moved = moved_camera(first, motion)
    start, end = (-pose[:, :3].T @ pose[:, 3] for pose in (first, moved))
    center = start + STEP_SCALE * (end - start)
    return np.hstack([moved[:, :3], (-moved[:, :3] @ center)[:, None]])


def synthetic_scenes(count: int, seed: int, size: tuple[int, int]) -> list[AskedScene]:
    from shared.synthetic.mmsi import MOTIONS, _camera, _scene, moved_camera
    from shared.synthetic.render import default_intrinsic, render_view

    scenes = []
    motions = list(MOTIONS)
    for index in range(count):
        rng = np.random.default_rng([seed, index])
        scene = _scene(rng)
        first = _camera(scene, rng)
        motion = motions[index % len(motions)]
        views = 2 + index % 3
        order = random.Random(f"{seed}:{index}")
        a, b = order.sample(range(1, views + 1), 2)
        others = iter(moved_camera(first, name) for name in OTHER_VIEWS)
        poses = [
            first if v == a else _moved(first, motion) if v == b else next(others)
            for v in range(1, views + 1)
        ]
        intrinsic = default_intrinsic(*size)
        rendered = [render_view(scene, pose, intrinsic, *size) for pose in poses]
        exact = {
            "depths": [r.depth for r in rendered],
            "extrinsics": np.array(poses),
            "intrinsics": np.array([intrinsic] * views),
        }
        specs = synthetic_specs(motion, views, (a, b), order)
        scenes.append(
            AskedScene(f"syn{index:02d} {motion}", "synthetic", [r.rgb for r in rendered], specs, exact)
        )
    return scenes


def templering_scenes(starts: list[int], steps: list[int], seed: int) -> list[AskedScene]:
    from bench.templering import ring, subset
    from bench.templering_data import load_cameras, realdata_dir
    from bench.templering_questions import TempleSet, claims_for, photos, true_extrinsics, true_quantities

    root = realdata_dir()
    if root is None:
        raise SystemExit("templeRing not found (set PYSPATIAL_REALDATA_DIR)")
    cameras, azimuths = load_cameras(root), ring(root)
    scenes = []
    for sideways in (False, True):
        for step in steps:
            for start in starts:
                images = subset(azimuths, start, 2, step)
                if images is None:
                    continue
                photo_set = TempleSet(tuple(images), sideways)
                truth = true_extrinsics(cameras, photo_set)
                rng = random.Random(f"{seed}:{photo_set.label()}")
                specs = []
                for pair in ((1, 2), (2, 1)):
                    words = true_quantities(truth[pair[0] - 1], truth[pair[1] - 1])
                    for quantity in ("translation", "rotation", "position"):
                        options = claims_for(words, quantity, rng)
                        if options is not None:
                            specs.append(AskSpec(2, pair, quantity, *options))
                specs.append(_abstaining(specs[0], 2, specs[0].pair, rng))
                setting = "sideways" if sideways else "upright"
                scenes.append(AskedScene(photo_set.label(), setting, photos(root, cameras, photo_set), specs))
    return scenes


@contextmanager
def _services(work: Path, backbone: str) -> Iterator[tuple[ReconClient, AgentClient]]:
    env = {
        "PYSPATIAL_DATA_DIR": str(work / "service-data"),
        "PYSPATIAL_CACHE_NAMESPACE": f"bench-paraphrase-{uuid.uuid4().hex}",
        "PYSPATIAL_BACKBONE": backbone,
        **OFFLINE_ENV,
    }
    with ExitStack() as stack:
        recon = stack.enter_context(running_service("services.recon.app:create_app", env))
        agent_env = {**env, "PYSPATIAL_RECON_URL": recon.url}
        agent = stack.enter_context(running_service("services.agent.app:create_app", agent_env))
        yield (
            stack.enter_context(ReconClient(recon.url)),
            stack.enter_context(AgentClient(agent.url, timeout=600)),
        )


def _judge(item: ParaphraseItem, answer: str | None, reason: str | None, tally: Tally) -> str:
    counts = tally.counts
    reading = read_question(item.text, item.image_count)
    if item.abstain is not None:
        counts["must abstain"] += 1
        if answer is None:
            counts["refused (must abstain)"] += 1
            named = re.search(REASON_WORDS[item.abstain], (reason or "").lower()) is not None
            counts["reason names it"] += named
        else:  # the option that holds may still be one clear claim: right or wrong is worth knowing
            counts["must abstain, answered " + ("right" if answer == item.answer else "wrong")] += 1
        return "must abstain: " + ("refused" if answer is None else f"answered {answer}")
    counts["questions"] += 1
    if answer is None:
        counts["abstained"] += 1
        tally.reasons[_reason_kind(reason)] += 1
        return "abstained"
    counts["answered"] += 1
    verdict = "right" if answer == item.answer else "wrong"
    counts[verdict] += 1
    if reading.views != item.views:
        counts["answered, pair misread"] += 1
    return verdict


def _reason_kind(reason: str | None) -> str:
    """A reason shortened to its first clause, so that like reasons count together."""
    text = re.sub(r"\d+", "N", (reason or "none").strip())
    return re.split(r"[:;(.]", text, maxsplit=1)[0][:90]


def ask(
    scenes: list[AskedScene], split: str, agent: AgentClient, backbone: str, seed: int, verbose: bool
) -> Tally:
    wordings = load_wordings(split)
    tally = Tally()
    for scene in scenes:
        for index, spec in enumerate(scene.specs):
            rng = random.Random(f"{seed}:{split}:{scene.label}:{index}")
            item = phrase(spec, wordings, split, f"{scene.label}#{index}", rng)
            try:
                response = agent.solve(item.text, scene_id=scene.scene_id, backbone=backbone)
                answer, reason = response.answer, response.answer_reason
            except ServiceError as error:
                answer, reason = None, f"request failed: {error}"
            verdict = _judge(item, answer, reason, tally)
            tally.counts[f"{scene.setting}: {verdict}"] += 1
            if verbose and split == "tuning" and verdict not in ("right",):
                print(
                    f"[{scene.label}] {verdict} (truth {item.answer}): {item.text!r} -> {reason}", flush=True
                )
    return tally


def _print(split: str, tally: Tally, settings: list[str]) -> None:
    c = tally.counts
    cells = [c[k] for k in ("questions", "answered", "right", "wrong", "abstained", "answered, pair misread")]
    answered = f"{c['must abstain, answered right']} / {c['must abstain, answered wrong']}"
    cells += [c["must abstain"], c["refused (must abstain)"], c["reason names it"], answered]
    print(f"| {split} | all | " + " | ".join(map(str, cells)) + " |")
    for setting in settings:
        part = [c[f"{setting}: {v}"] for v in ("right", "wrong", "abstained")]
        print(
            f"| {split} | {setting} | | {part[0] + part[1]} | {part[0]} | {part[1]} | {part[2]} | | | | | |"
        )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="pyspatial bench paraphrase_answers", description=__doc__)
    parser.add_argument("--source", choices=("synthetic", "templering"), default="synthetic")
    parser.add_argument("--scenes", type=int, default=26, help="synthetic: rooms (13 motions, cycled)")
    parser.add_argument("--starts", default="1,5,9,13,17,21")
    parser.add_argument("--steps", default="1,2,3,4,6")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--splits", default=",".join(SPLITS))
    parser.add_argument(
        "--verbose", action="store_true", help="print the tuning questions not answered right"
    )
    args = parser.parse_args(argv)
    started = time.perf_counter()
    if args.source == "synthetic":
        scenes, backbone = synthetic_scenes(args.scenes, args.seed, (320, 240)), "posed-rgbd"
    else:
        starts, steps = ([int(s) for s in text.split(",")] for text in (args.starts, args.steps))
        scenes, backbone = templering_scenes(starts, steps, args.seed), "classical"
    settings = sorted({scene.setting for scene in scenes})
    with (
        tempfile.TemporaryDirectory(prefix="bench-paraphrase-") as work,
        _services(Path(work), backbone) as (
            recon,
            agent,
        ),
    ):
        for scene in scenes:
            extra = scene.exact or {}
            scene.scene_id = recon.upload_scene(scene.images, **extra).scene_id
        tallies = {
            split: ask(scenes, split, agent, backbone, args.seed, args.verbose)
            for split in args.splits.split(",")
        }
    print(
        "\n| split | setting | questions | answered | right | wrong | abstained | "
        "answered with pair misread | must abstain | refused | reason names it | answered right / wrong |"
    )
    print("| --- | --- |" + " ---: |" * 10)
    for split, tally in tallies.items():
        _print(split, tally, settings)
    for split, tally in tallies.items():
        print(f"\n{split}: abstentions by reason")
        for reason, number in tally.reasons.most_common():
            print(f"- {number}: {reason}")
    print(f"\n{len(scenes)} scenes, {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
