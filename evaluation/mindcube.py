"""MindCube: multiple-choice spatial questions over a few views, scored by the option letter.

``evaluate_mindcube`` reads the JSONL, asks a solver (pySpatial or the answer model alone) each
question with bounded concurrency, saves one record per item as it goes, and summarizes accuracy
overall and per setting (rotation / among / around) the way the pySpatial paper reports it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
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
    return answer_letter(item.gt_answer, item.question) or item.gt_answer.strip()


def score_mindcube(item: BenchmarkItem, prediction: Prediction) -> dict[str, Any]:
    """The result record of one item: correct when the normalized letters match."""
    predicted = None if prediction.error else answer_letter(prediction.answer, item.question)
    truth = gt_letter(item)
    return {
        "id": item.id,
        "setting": item.setting,
        "type": item.type,
        "question": item.question,
        "gt_answer": truth,
        "prediction": predicted,
        "correct": predicted is not None and predicted == truth,
        "answered": predicted is not None,
        **prediction.as_record(),
    }


@dataclass
class EvaluationRun:
    records: list[dict[str, Any]]
    summary: MindCubeSummary


def evaluate_mindcube(
    jsonl: Path,
    image_root: Path,
    solve: Callable[[BenchmarkItem], Prediction],
    results_path: Path,
    limit: int | None = None,
    concurrency: int = 4,
    resume: bool = False,
    console: Console | None = None,
    show_progress: bool = True,
    items: list[BenchmarkItem] | None = None,
) -> EvaluationRun:
    """Run every item (or the first ``limit``) through ``solve`` and summarize."""
    items = items if items is not None else read_mindcube(jsonl, image_root, limit)
    records = run_items(
        items,
        lambda item: score_mindcube(item, solve_safely(solve, item)),
        results_path,
        concurrency=concurrency,
        resume=resume,
        console=console,
        show_progress=show_progress,
    )
    return EvaluationRun(records=records, summary=summarize_mindcube(records))
