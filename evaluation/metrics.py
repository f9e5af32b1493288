"""Benchmark metrics over result records (the dicts the runner writes, one per item).

MindCube: accuracy overall and per setting (rotation / among / around), as the pySpatial paper
reports it, plus how often each stage of the agent succeeded and how long each took.
Omni3D-Bench: exact-match accuracy for yes/no, multiple choice and counts; mean relative accuracy
(MRA) for other numbers.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from evaluation.dataset import MINDCUBE_SETTINGS

STAGES = ("reconstruction", "codegen", "execution", "answering")
# Omni3D-Bench's thresholds: 0.50, 0.55, ..., 0.95.
MRA_THRESHOLDS = tuple(round(0.50 + 0.05 * step, 2) for step in range(10))


def relative_error(prediction: float, truth: float) -> float:
    """|pred - gt| / |gt|; with gt = 0 only an exact 0 is right (error 0), anything else is infinite."""
    if truth == 0:
        return 0.0 if prediction == 0 else math.inf
    return abs(prediction - truth) / abs(truth)


def mean_relative_accuracy(prediction: float | None, truth: float) -> float:
    """Fraction of thresholds t in MRA_THRESHOLDS with relative error < 1 - t (0 without a number)."""
    if prediction is None or not math.isfinite(prediction):
        return 0.0
    error = relative_error(prediction, truth)
    # Round the bound so that 1 - 0.95 is 0.05 and not 0.04999999999999993.
    hits = sum(error < round(1.0 - threshold, 10) for threshold in MRA_THRESHOLDS)
    return hits / len(MRA_THRESHOLDS)


@dataclass
class Score:
    """A sum of per-item scores (0/1 for accuracy, 0..1 for MRA) over a count of items."""

    total: float = 0.0
    count: int = 0

    def add(self, value: float) -> None:
        self.total += value
        self.count += 1

    @property
    def value(self) -> float | None:
        return self.total / self.count if self.count else None


def _rate(records: list[dict[str, Any]], key: str) -> Score:
    """How often a stage flag is true, over the records where the flag applies (not None)."""
    score = Score()
    for record in records:
        if record.get(key) is not None:
            score.add(float(bool(record[key])))
    return score


def _mean_stage_ms(records: list[dict[str, Any]]) -> dict[str, float | None]:
    means: dict[str, float | None] = {}
    for stage in STAGES:
        values = [
            float(r["timings"][f"{stage}_ms"])
            for r in records
            if r.get("timings") and r["timings"].get(f"{stage}_ms") is not None
        ]
        means[stage] = sum(values) / len(values) if values else None
    return means


OVERALL = "overall"
EXCLUDED_FROM_OVERALL = ("translation",)  # MindCube leaves its translation items out of the overall


@dataclass
class MindCubeSummary:
    system: str
    accuracy: dict[str, Score]  # correct / all items (MindCube's denominator): "overall" and settings
    parse_success: Score  # a program was produced
    execution_success: Score  # a program ran to the end
    answer_success: Score  # an answer letter was given
    errors: int  # items whose request failed outright
    mean_ms: dict[str, float | None] = field(default_factory=dict)
    # correct / answered items (the pySpatial paper's code divides by the items it answered)
    accuracy_answered: dict[str, Score] = field(default_factory=dict)
    code_models: Counter = field(default_factory=Counter)  # what wrote the programs, with counts
    answer_models: Counter = field(default_factory=Counter)  # what answered, with counts
    code_fallbacks: int = 0  # programs the offline planner wrote because the code model failed
    images_only: int = 0  # answers from the photos alone because no program ran

    @property
    def count(self) -> int:
        return self.accuracy[OVERALL].count


def is_code_fallback(code_model: str | None) -> bool:
    return bool(code_model) and "(fallback:" in code_model


def summarize_mindcube(records: Iterable[dict[str, Any]], system: str | None = None) -> MindCubeSummary:
    """Accuracy overall and per setting, over all items (failed requests and unanswered items count
    as wrong) and over answered items; translation items are scored but left out of the overall."""
    records = list(records)
    accuracy = {OVERALL: Score(), **{s: Score() for s in MINDCUBE_SETTINGS}}
    answered = {OVERALL: Score(), **{s: Score() for s in MINDCUBE_SETTINGS}}
    for record in records:
        correct = float(bool(record.get("correct")))
        setting = record.get("setting") or "other"
        keys = [setting] if setting in EXCLUDED_FROM_OVERALL else [OVERALL, setting]
        for key in keys:
            accuracy.setdefault(key, Score()).add(correct)
            if record.get("answered"):
                answered.setdefault(key, Score()).add(correct)
    code_models = Counter(r["code_model"] for r in records if r.get("code_model"))
    return MindCubeSummary(
        system=system or _system_of(records),
        accuracy=accuracy,
        parse_success=_rate(records, "program_produced"),
        execution_success=_rate(records, "executed"),
        answer_success=_rate(records, "answered"),
        errors=sum(1 for r in records if r.get("error")),
        mean_ms=_mean_stage_ms(records),
        accuracy_answered=answered,
        code_models=code_models,
        answer_models=Counter(r["answer_model"] for r in records if r.get("answer_model")),
        code_fallbacks=sum(count for name, count in code_models.items() if is_code_fallback(name)),
        images_only=sum(1 for r in records if r.get("fallback") == "images_only"),
    )


OMNI3D_KINDS = ("yes/no", "multiple choice", "count", "numeric")


@dataclass
class Omni3DSummary:
    system: str
    by_kind: dict[str, Score]  # exact-match accuracy, or MRA for "numeric"
    answer_success: Score
    errors: int
    mean_ms: dict[str, float | None] = field(default_factory=dict)

    @property
    def count(self) -> int:
        return sum(score.count for score in self.by_kind.values())


def summarize_omni3d(records: Iterable[dict[str, Any]], system: str | None = None) -> Omni3DSummary:
    records = list(records)
    by_kind = {kind: Score() for kind in OMNI3D_KINDS}
    for record in records:
        if record.get("kind") in by_kind:  # records the runner wrote for a crashed scorer have none
            by_kind[record["kind"]].add(float(record.get("score") or 0.0))
    return Omni3DSummary(
        system=system or _system_of(records),
        by_kind=by_kind,
        answer_success=_rate(records, "answered"),
        errors=sum(1 for r in records if r.get("error")),
        mean_ms=_mean_stage_ms(records),
    )


def _system_of(records: list[dict[str, Any]]) -> str:
    # A failed request only knows which system was asked, not which models answered: prefer the others.
    answered = [r for r in records if not r.get("error")] or records
    systems = sorted({r.get("system") for r in answered if r.get("system")})
    return " / ".join(systems) if systems else "unknown"
