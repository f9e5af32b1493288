"""MindCube: multiple-choice spatial questions over a few views, scored by the option letter.

``evaluate_mindcube`` reads the JSONL, asks a solver (pySpatial or the answer model alone) each
question with bounded concurrency, saves one record per item as it goes, and summarizes accuracy
overall and per setting (rotation / among / around) the way the pySpatial paper reports it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console

from evaluation.answers import answer_letter
from evaluation.dataset import BenchmarkItem, read_mindcube
from evaluation.metrics import MindCubeSummary, summarize_mindcube
from evaluation.runner import run_items
from evaluation.solvers import Prediction, solve_safely

# What the baseline model is told after the question (the agent's answerer has its own prompt).
MINDCUBE_INSTRUCTION = "Answer with the letter of the correct option only."


def gt_letter(item: BenchmarkItem) -> str:
    """The ground-truth letter; MindCube writes "C" but some exports write "C. Left"."""
    return answer_letter(item.gt_answer, item.intent) or item.gt_answer.strip()


def score_mindcube(item: BenchmarkItem, prediction: Prediction) -> dict[str, Any]:
    """The result record of one item: correct when the normalized letters match.

    ``answer`` (the letter, or null) and ``gt_answer`` are the fields MindCube's own evaluator reads,
    so a results file can be scored by it unchanged; ``raw_answer`` keeps what the solver said.
    """
    predicted = None if prediction.error else answer_letter(prediction.answer, item.intent)
    truth = gt_letter(item)
    return {
        "id": item.id,
        "setting": item.setting,
        "type": item.type,
        "question": item.question,
        "gt_answer": truth,
        "answer": predicted,
        "prediction": predicted,
        "correct": predicted is not None and predicted == truth,
        "answered": predicted is not None,
        **prediction.as_record(),
    }


@dataclass
class EvaluationRun:
    records: list[dict[str, Any]]
    summary: MindCubeSummary
    skipped: list[str] = field(default_factory=list)  # warnings about items left out (missing images)


def evaluate_mindcube(
    jsonl: Path,
    image_root: Path | None,
    solve: Callable[[BenchmarkItem], Prediction],
    results_path: Path,
    limit: int | None = None,
    concurrency: int = 4,
    resume: bool = False,
    console: Console | None = None,
    show_progress: bool = True,
    items: list[BenchmarkItem] | None = None,
) -> EvaluationRun:
    """Run every item (or the first ``limit``) through ``solve`` and summarize. Items whose images
    are missing are skipped with a warning (printed, and kept in ``EvaluationRun.skipped``)."""
    skipped: list[str] = []
    items = items if items is not None else read_mindcube(jsonl, image_root, limit, skipped)
    if console is not None:
        for warning in skipped:
            console.print(f"[yellow]warning:[/yellow] {warning}", highlight=False)
    records = run_items(
        items,
        lambda item: score_mindcube(item, solve_safely(solve, item)),
        results_path,
        concurrency=concurrency,
        resume=resume,
        console=console,
        show_progress=show_progress,
    )
    return EvaluationRun(records=records, summary=summarize_mindcube(records), skipped=skipped)
