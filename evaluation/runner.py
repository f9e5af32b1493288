"""Run a benchmark item by item with bounded concurrency, saving each result the moment it is known.

The results file is JSONL, one record per item, appended and flushed as items finish, so a crash
or Ctrl-C loses only the items in flight. With ``resume`` the ids already in the file are skipped;
a half-written last line (the process died mid-write) is dropped and its item is run again.
"""

from __future__ import annotations

import json
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from evaluation.dataset import BenchmarkItem

Record = dict[str, Any]
Evaluate = Callable[[BenchmarkItem], Record]


def read_results(path: Path) -> list[Record]:
    """The complete records of a results file; a torn last line is ignored."""
    records: list[Record] = []
    if not path.exists():
        return records
    with path.open(encoding="utf-8") as handle:
        for line in handle:
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue  # only the line being written when the process died can be torn
            if isinstance(record, dict) and "id" in record:
                records.append(record)
    return records


def _failure_record(item: BenchmarkItem, error: BaseException) -> Record:
    """A wrong answer for an item whose evaluation itself broke: the run goes on."""
    return {
        "id": item.id,
        "setting": item.setting,
        "correct": False,
        "answered": False,
        "error": f"{type(error).__name__}: {error}",
        "traceback": "".join(traceback.format_exception(error))[-4000:],
    }


def _safe(evaluate: Evaluate, item: BenchmarkItem) -> Record:
    try:
        return evaluate(item)
    except Exception as error:  # any failure of one item is that item's result, never the run's end
        return _failure_record(item, error)


def run_items(
    items: Sequence[BenchmarkItem],
    evaluate: Evaluate,
    results_path: Path,
    concurrency: int = 4,
    resume: bool = False,
    console: Console | None = None,
    show_progress: bool = True,
) -> list[Record]:
    """Evaluate the items (skipping finished ones when resuming); returns their records in item order.

    Records of ids that are not among ``items`` stay in the file but are not returned.
    """
    results_path = Path(results_path)
    results_path.parent.mkdir(parents=True, exist_ok=True)
    previous = read_results(results_path) if resume else []
    # Rewrite what survives, so that appends never follow a torn line; a fresh run starts empty.
    with results_path.open("w", encoding="utf-8") as handle:
        handle.writelines(json.dumps(r) + "\n" for r in previous)

    by_id: dict[str, Record] = {r["id"]: r for r in previous}
    pending = [item for item in items if item.id not in by_id]
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        disable=not show_progress,
    )
    with progress, results_path.open("a", encoding="utf-8") as out:
        task = progress.add_task("evaluating", total=len(items), completed=len(items) - len(pending))
        pool = ThreadPoolExecutor(max_workers=max(1, concurrency))
        try:
            futures = [pool.submit(_safe, evaluate, item) for item in pending]
            for future in as_completed(futures):
                record = future.result()
                out.write(json.dumps(record) + "\n")
                out.flush()  # the record survives a crash of this process from now on
                by_id[record["id"]] = record
                progress.advance(task)
        finally:
            # On Ctrl-C wait only for the items in flight, not for the whole queue.
            pool.shutdown(wait=True, cancel_futures=True)
    return [by_id[item.id] for item in items if item.id in by_id]
