"""41 camera questions on templeRing photos in MMSI-Bench's parquet schema, two wordings, eval mmsi.

    python -m bench mmsi_templering [--out-dir DIR] [--splits tuning,heldout] [--write-only]

The questions: "Motion (Cam.)" (the camera's translation or rotation from view A to view B) and
"Positional Relationship (Cam.–Cam.)" (where view B's camera is, seen from view A's), on pairs
and triples of the templeRing ring (first pass, 7.7-23 degrees apart; as taken and all turned
90 degrees; either order), each option's truth from the calibrated cameras
(bench/templering_questions.py). The same 41 photo sets, pairs, options and answers are worded
twice from the paraphrase corpus's lists (tests/support/paraphrases.py): once with the tuning
wordings, once with the held-out ones. Each is written as a parquet file with MMSI-Bench's published
columns (id, images, question_type, question with "Options: A: ...", answer, thought, difficulty,
mean_normed_duration_seconds), then scored by `pyspatial eval mmsi` against freshly started recon
and agent services with no language model (classical backbone, no focal given: the offline planner
and answerer). Per wording: answered, right, wrong, per question type.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
import uuid
from collections import Counter
from pathlib import Path

import cv2

from bench.templering import ring, subset
from bench.templering_data import load_cameras, realdata_dir
from bench.templering_questions import TempleSet, claims_for, photos, true_extrinsics, true_quantities
from shared.local.services import running_service
from shared.synthetic.mmsi import CAM_CAM, MOTION_CAM, write_parquet
from tests.support.paraphrases import SPLITS, AskSpec, load_wordings, phrase

QUOTA = {"position": 12, "translation": 15, "rotation": 14}  # 41 questions
STARTS = (1, 4, 7, 10, 13, 16, 19, 22, 25)  # the first pass of the ring (images 1-31)
OFFLINE_ENV = {"PYSPATIAL_CODE_MODEL": "", "PYSPATIAL_ANSWER_MODEL": ""}


def _candidates(azimuths: dict[int, float], seed: int) -> list[tuple[TempleSet, tuple[int, int]]]:
    """Photo sets with the pair asked: pairs 1-3 ring steps apart and triples, either order."""
    found = []
    for step in (1, 2, 3):
        for start in STARTS:
            for count in (2, 3):
                images = subset(azimuths, start, count, step if count == 2 else 1)
                if images is None or max(images) >= 32:
                    continue
                for sideways in (False, True):
                    pairs = [(1, 2), (2, 1)] if count == 2 else [(1, 3), (3, 1), (2, 3), (3, 2)]
                    found += [(TempleSet(tuple(images), sideways), pair) for pair in pairs]
    random.Random(seed).shuffle(found)
    return found


def question_specs(seed: int = 0) -> list[tuple[TempleSet, AskSpec, dict[str, str]]]:
    """The 41 questions: photo set, spec (pair, quantity, options, the true one), true words."""
    root = realdata_dir()
    if root is None:
        raise SystemExit("templeRing not found (set PYSPATIAL_REALDATA_DIR)")
    cameras = load_cameras(root)
    rng = random.Random(seed)
    wanted = Counter(QUOTA)
    chosen = []
    for index, (photo_set, pair) in enumerate(_candidates(ring(root), seed)):
        quantity = next((q for q in QUOTA if wanted[q] > 0 and (index % 3 == list(QUOTA).index(q))), None)
        quantity = quantity or next((q for q in QUOTA if wanted[q] > 0), None)
        if quantity is None:
            break
        truth = true_extrinsics(cameras, photo_set)
        words = true_quantities(truth[pair[0] - 1], truth[pair[1] - 1])
        options = claims_for(words, quantity, rng)
        if options is None:
            continue
        claims, true_index = options
        spec = AskSpec(len(photo_set.images), pair, quantity, claims, true_index)
        chosen.append((photo_set, spec, words))
        wanted[quantity] -= 1
    return chosen


def _png(picture) -> bytes:
    ok, data = cv2.imencode(".png", cv2.cvtColor(picture, cv2.COLOR_RGB2BGR))
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return data.tobytes()


def mmsi_rows(split: str, seed: int = 0, limit: int | None = None) -> list[dict]:
    """The 41 questions (the first `limit`) in one split's wordings, as rows of MMSI-Bench's schema."""
    root = realdata_dir()
    cameras = load_cameras(root)
    wordings = load_wordings(split)
    rows = []
    for index, (photo_set, spec, words) in enumerate(question_specs(seed)[:limit]):
        item = phrase(
            spec, wordings, split, f"temple{index:02d}", random.Random(f"{seed}:{split}:{index}"), "mmsi"
        )
        said = ", ".join(f"{name} {word}" for name, word in words.items())
        rows.append(
            {
                "id": f"temple{index:02d}",
                "images": [_png(p) for p in photos(root, cameras, photo_set)],
                "question_type": CAM_CAM if spec.quantity == "position" else MOTION_CAM,
                "question": item.text,
                "answer": item.answer,
                "thought": f"templeRing {photo_set.label()}, views {spec.pair[0]} -> {spec.pair[1]}: {said}.",
                "difficulty": "easy",
                "mean_normed_duration_seconds": 10.0,
            }
        )
    return rows


def _tally(predictions: Path) -> dict[str, Counter]:
    """Per question type (and "all"): questions, answered, right, wrong."""
    counts: dict[str, Counter] = {}
    for line in predictions.read_text(encoding="utf-8").splitlines():
        record = json.loads(line)
        for name in ("all", record["question_type"]):
            row = counts.setdefault(name, Counter())
            row["questions"] += 1
            row["answered"] += bool(record["answered"])
            row["right"] += bool(record["correct"])
            row["wrong"] += bool(record["answered"]) and not record["correct"]
    return counts


def _eval(parquet: Path, agent_url: str, out: Path) -> None:
    command = [sys.executable, "-m", "cli.main", "eval", "mmsi", "--parquet", str(parquet)]
    command += ["--agent-url", agent_url, "--backbone", "classical", "--out", str(out)]
    command += ["--concurrency", "1", "--no-progress"]
    print("$", " ".join(command[1:]), flush=True)
    subprocess.run(command, check=True)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="pyspatial bench mmsi_templering", description=__doc__)
    parser.add_argument("--out-dir", type=Path, default=None)
    parser.add_argument("--splits", default=",".join(SPLITS))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--write-only", action="store_true", help="only write the parquet files")
    parser.add_argument("--agent-url", default=None, help="an agent already running (else one is started)")
    args = parser.parse_args(argv)
    work = args.out_dir or Path(tempfile.mkdtemp(prefix="mmsi-templering-"))
    work.mkdir(parents=True, exist_ok=True)
    splits = args.splits.split(",")
    parquets = {}
    for split in splits:
        parquets[split] = work / f"templeRing_{split}.parquet"
        write_parquet(mmsi_rows(split, args.seed), parquets[split])
        print(f"wrote {parquets[split]}", flush=True)
    if args.write_only:
        return
    env = {
        "PYSPATIAL_DATA_DIR": str(work / "service-data"),
        "PYSPATIAL_CACHE_NAMESPACE": f"bench-mmsi-temple-{uuid.uuid4().hex}",
        "PYSPATIAL_BACKBONE": "classical",
        **OFFLINE_ENV,
    }
    if os.environ.get("REDIS_URL"):
        env["REDIS_URL"] = os.environ["REDIS_URL"]
    if args.agent_url:
        for split in splits:
            _eval(parquets[split], args.agent_url, work / f"{split}.jsonl")
    else:
        with running_service("services.recon.app:create_app", env) as recon:
            with running_service(
                "services.agent.app:create_app", {**env, "PYSPATIAL_RECON_URL": recon.url}
            ) as agent:
                for split in splits:
                    _eval(parquets[split], agent.url, work / f"{split}.jsonl")
    print("\n| wording | question type | questions | answered | right | wrong |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for split in splits:
        for name, row in sorted(_tally(work / f"{split}.jsonl").items()):
            cells = " | ".join(str(row[k]) for k in ("questions", "answered", "right", "wrong"))
            print(f"| {split} | {name} | {cells} |")
    print(f"\nfiles in {work}")


if __name__ == "__main__":
    main()
