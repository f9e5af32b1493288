"""Accuracy of pySpatial on a synthetic MindCube-style set with known answers.

    python -m bench.eval_synthetic --questions 100 --seed 0 --backbone posed-rgbd

Renders procedural scenes (shared/synthetic), starts the recon and agent services (or uses the
URLs given), runs the MindCube harness and prints accuracy by setting and mean time per stage.

Without language models the agent uses its offline planner and answerer, which can answer only the
camera-motion families ("motion": which way did I move, "turn": which way did I turn) from the
words of the motion clue; the other families need a vision model and come back with answer=None.
So the accuracy table is computed on the motion families, and a second table says, per family,
how many questions there were, how many were answered and how many came back with answer=None.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import tempfile
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

from rich.table import Table

from evaluation.dataset import read_mindcube
from evaluation.metrics import summarize_mindcube
from evaluation.mindcube import evaluate_mindcube
from evaluation.report import mindcube_report, report_console
from evaluation.solvers import pyspatial_solver
from shared.local.services import running_service
from shared.synthetic import make_dataset

MOTION_FAMILIES = ("motion", "turn")
QUESTIONS_PER_SCENE = 4  # make_dataset asks 4 to 6 per scene; this over-generates slightly


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python -m bench.eval_synthetic", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--questions", type=int, default=100, help="About this many questions.")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--backbone", default="posed-rgbd", help="posed-rgbd (exact depth) or classical.")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--concurrency", type=int, default=2)
    parser.add_argument(
        "--out-dir", type=Path, default=None, help="Data set and results; a temp dir if unset."
    )
    parser.add_argument("--agent-url", default=None, help="Use a running agent instead of starting one.")
    parser.add_argument("--recon-url", default=None, help="The running agent's recon service.")
    parser.add_argument("--no-progress", action="store_true")
    return parser.parse_args(argv)


@contextlib.contextmanager
def _services(args: argparse.Namespace, work_dir: Path) -> Iterator[tuple[str, str | None]]:
    """(agent URL, recon URL): the given ones, or freshly started services with a private cache."""
    if args.agent_url:
        yield args.agent_url, args.recon_url
        return
    env = {
        "PYSPATIAL_DATA_DIR": str(work_dir / "service-data"),
        "PYSPATIAL_CACHE_NAMESPACE": f"bench-eval-{uuid.uuid4().hex}",
        "PYSPATIAL_BACKBONE": args.backbone,
    }
    if os.environ.get("REDIS_URL"):
        env["REDIS_URL"] = os.environ["REDIS_URL"]
    with running_service("services.recon.app:create_app", env) as recon:
        with running_service(
            "services.agent.app:create_app", {**env, "PYSPATIAL_RECON_URL": recon.url}
        ) as agent:
            yield agent.url, recon.url


def family_table(records: list[dict], families: dict[str, str]) -> Table:
    """Per question family: how many, answered, answer=None, failed requests, correct."""
    table = Table(title="Question families")
    for name in ("Family", "Questions", "Answered", "answer=None", "Errors", "Correct"):
        table.add_column(name, justify="left" if name == "Family" else "right")
    for family in sorted(set(families.values())):
        rows = [r for r in records if families[r["id"]] == family]
        table.add_row(
            family,
            str(len(rows)),
            str(sum(1 for r in rows if r.get("raw_answer") is not None)),
            str(sum(1 for r in rows if r.get("raw_answer") is None and not r.get("error"))),
            str(sum(1 for r in rows if r.get("error"))),
            str(sum(1 for r in rows if r.get("correct"))),
        )
    return table


def main(argv: list[str] | None = None) -> int:
    args = _arguments(argv)
    console = report_console()
    with contextlib.ExitStack() as stack:
        work_dir = args.out_dir or Path(
            stack.enter_context(tempfile.TemporaryDirectory(prefix="eval-synth-"))
        )
        data_dir = work_dir / "dataset"
        started = time.perf_counter()
        scenes = math.ceil(args.questions / QUESTIONS_PER_SCENE)
        jsonl = make_dataset(
            data_dir, num_scenes=scenes, seed=args.seed, width=args.width, height=args.height
        )
        items = read_mindcube(jsonl, data_dir, limit=args.questions)
        console.print(
            f"{len(items)} questions from {scenes} scenes ({args.width}x{args.height}) "
            f"in {time.perf_counter() - started:.1f}s; backbone {args.backbone}"
        )
        agent_url, recon_url = stack.enter_context(_services(args, work_dir))
        results = work_dir / f"results-{args.backbone}-seed{args.seed}.jsonl"
        started = time.perf_counter()
        with pyspatial_solver(agent_url, data_dir, args.backbone, recon_url) as solver:
            run = evaluate_mindcube(
                jsonl,
                data_dir,
                solver.solve,
                results,
                concurrency=args.concurrency,
                console=console,
                show_progress=not args.no_progress,
                items=items,
            )
        elapsed = time.perf_counter() - started

    families = {item.id: item.type or "unknown" for item in items}
    motion = [r for r in run.records if families[r["id"]] in MOTION_FAMILIES]
    console.print(family_table(run.records, families))
    console.print(
        mindcube_report(
            [summarize_mindcube(motion)], title="Accuracy (%) on the motion families (motion, turn)"
        )
    )
    console.print(mindcube_report([run.summary], title="Accuracy (%) on all families"))
    console.print(
        f"{len(run.records)} questions in {elapsed:.1f}s wall ({args.concurrency} at a time); "
        f"results: {results if args.out_dir else '(temporary directory, removed)'}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
