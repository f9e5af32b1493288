"""pySpatial on MMSI-style synthetic questions with exact answers, per MMSI question type.

    python -m bench.mmsi_synthetic --scenes 13 --seed 0

Writes the questions as a parquet file with MMSI-Bench's published schema (shared/synthetic/mmsi.py),
starts the recon and agent services (or uses --agent-url), and runs `pyspatial eval mmsi`'s harness
on it, plain and (with --circular) with rotated options. The photos go up as photos (no exact
cameras), so the backbone (default classical) reconstructs them; without language models the
offline planner and answerer answer the camera-motion questions and refuse the rest.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from bench.eval_synthetic import _services
from evaluation.mmsi import evaluate_mmsi, read_mmsi
from evaluation.report import mmsi_table, report_console
from evaluation.solvers import pyspatial_solver
from shared.synthetic.mmsi import mmsi_rows, write_parquet


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python -m bench.mmsi_synthetic", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--scenes", type=int, default=13, help="One motion question each (13 = every word).")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--backbone", default="classical")
    parser.add_argument("--circular", action="store_true")
    parser.add_argument("--types", nargs="*", default=None, help="Only these MMSI question types.")
    parser.add_argument("--concurrency", type=int, default=2)
    parser.add_argument("--out-dir", type=Path, default=None)
    parser.add_argument("--agent-url", default=None)
    parser.add_argument("--recon-url", default=None)
    parser.add_argument("--no-progress", action="store_true")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = _arguments(argv)
    console = report_console()
    work = args.out_dir or Path(tempfile.mkdtemp(prefix="mmsi-synthetic-"))
    work.mkdir(parents=True, exist_ok=True)
    parquet = work / "MMSI_synthetic.parquet"
    write_parquet(mmsi_rows(args.seed, args.scenes, (args.width, args.height)), parquet)
    items = read_mmsi(parquet, work / "images", types=args.types)
    with _services(args, work) as (agent_url, _), pyspatial_solver(agent_url, work, args.backbone) as solver:
        _, summary = evaluate_mmsi(
            items,
            solver.solve,
            work / "predictions.jsonl",
            circular=args.circular,
            concurrency=args.concurrency,
            console=console,
            show_progress=not args.no_progress,
        )
    console.print(mmsi_table(summary))
    (work / "summary.json").write_text(json.dumps(summary.as_dict(), indent=2) + "\n", encoding="utf-8")
    console.print(f"data, predictions and summary in {work}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
