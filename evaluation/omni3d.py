"""Omni3D-Bench: free-form questions about one image, with typed answers.

Scoring follows the benchmark: exact match for yes/no, multiple choice (a word or short phrase)
and counts (``answer_type`` int); mean relative accuracy for other numbers (``answer_type`` float).

Limitation: the agent's answerer picks option letters, and Omni3D-Bench questions have no options,
so for this benchmark the prediction is read from the agent's free text: its answer when that
parses as the expected kind, else its reasoning. A pySpatial score here measures how often that
text states the right value, which understates a model prompted for these answers directly.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rich.console import Console

from evaluation.answers import normalize_words, parse_number, parse_yes_no
from evaluation.dataset import BenchmarkItem, read_omni3d
from evaluation.metrics import Omni3DSummary, mean_relative_accuracy, summarize_omni3d
from evaluation.runner import run_items
from evaluation.solvers import Prediction, solve_safely

OMNI3D_INSTRUCTION = (
    "Reply with only the answer, inside <ans></ans> tags: yes or no, a word or short phrase, or a number."
)


def answer_kind(answer_type: str | None, gt_answer: str) -> str:
    """yes/no, multiple choice, count or numeric (the benchmark's four scoring rules)."""
    if answer_type == "int":
        return "count"
    if answer_type == "float":
        return "numeric"
    return "yes/no" if normalize_words(gt_answer) in ("yes", "no", "true", "false") else "multiple choice"


def _first_parsed(candidates: list[str | None], parse: Callable[[str | None], Any]) -> Any:
    for text in candidates:
        value = parse(text)
        if value is not None and value != "":
            return value
    return None


def score_omni3d(item: BenchmarkItem, prediction: Prediction) -> dict[str, Any]:
    kind = answer_kind(item.answer_type, item.gt_answer)
    candidates = [] if prediction.error else [prediction.answer, prediction.text]
    if kind == "numeric":
        value = _first_parsed(candidates, parse_number)
        score = mean_relative_accuracy(value, float(item.gt_answer))
    elif kind == "count":
        value = _first_parsed(candidates, parse_number)
        score = float(value is not None and value == round(float(item.gt_answer)))
    elif kind == "yes/no":
        value = _first_parsed(candidates, parse_yes_no)
        score = float(value is not None and value == parse_yes_no(item.gt_answer))
    else:
        value = _first_parsed(candidates, normalize_words)
        score = float(value is not None and value == normalize_words(item.gt_answer))
    return {
        "id": item.id,
        "kind": kind,
        "question": item.question,
        "gt_answer": item.gt_answer,
        "prediction": value,
        "score": score,
        "correct": score == 1.0,
        "answered": value is not None,
        **prediction.as_record(),
    }


@dataclass
class Omni3DRun:
    records: list[dict[str, Any]]
    summary: Omni3DSummary


def evaluate_omni3d(
    jsonl: Path,
    image_root: Path,
    solve: Callable[[BenchmarkItem], Prediction],
    results_path: Path,
    limit: int | None = None,
    concurrency: int = 4,
    resume: bool = False,
    console: Console | None = None,
    show_progress: bool = True,
) -> Omni3DRun:
    items = read_omni3d(jsonl, image_root, limit)
    records = run_items(
        items,
        lambda item: score_omni3d(item, solve_safely(solve, item)),
        results_path,
        concurrency=concurrency,
        resume=resume,
        console=console,
        show_progress=show_progress,
    )
    return Omni3DRun(records=records, summary=summarize_omni3d(records))
