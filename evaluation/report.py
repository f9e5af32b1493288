"""Tables of results, laid out as the pySpatial paper reports them (rich tables for the terminal).

Separate tables keep each within a terminal's width: the paper's accuracy table (over all items and
over answered items), the models table (what wrote the programs and what answered, fallbacks
counted) and the pipeline table (how often each stage succeeded, mean milliseconds per stage).
"""

from __future__ import annotations

from collections.abc import Sequence

from rich.console import Console, Group
from rich.table import Table

from evaluation.dataset import MINDCUBE_SETTINGS
from evaluation.metrics import (
    EXCLUDED_FROM_OVERALL,
    OMNI3D_KINDS,
    OVERALL,
    STAGES,
    MindCubeSummary,
    Omni3DSummary,
    Score,
)

NOT_APPLICABLE = "-"
STAGE_HEADINGS = {"reconstruction": "Recon", "codegen": "Codegen", "execution": "Exec", "answering": "Answer"}
MIN_FILE_WIDTH = 132  # when printing to a file or pipe, where rich would assume 80 columns


def report_console() -> Console:
    """A console for the tables: the terminal's width, or a wide one when the output is a file."""
    console = Console()
    return console if console.is_terminal else Console(width=max(console.width, MIN_FILE_WIDTH))


def percent(score: Score) -> str:
    """The score as a percentage with one decimal, "-" when nothing was counted."""
    return NOT_APPLICABLE if score.value is None else f"{100.0 * score.value:.1f}"


def milliseconds(value: float | None) -> str:
    return NOT_APPLICABLE if value is None else f"{value:.0f}"


DENOMINATORS = (
    ("all items (MindCube)", "accuracy"),
    ("answered (paper's code)", "accuracy_answered"),
)


def mindcube_accuracy_table(
    summaries: Sequence[MindCubeSummary], title: str = "MindCube accuracy (%)"
) -> Table:
    """The paper's table: accuracy overall and per setting, one row per system and denominator.

    MindCube divides by all items (unanswered ones count as wrong); the pySpatial paper's code divides
    by the items it answered. Both rows are shown, labelled, so either published table can be
    compared. N is the overall denominator. Translation items are left out of Overall (as MindCube
    does) and get their own column when present.
    """
    translation = any(EXCLUDED_FROM_OVERALL[0] in summary.accuracy for summary in summaries)
    keys = (OVERALL, *MINDCUBE_SETTINGS, *(EXCLUDED_FROM_OVERALL if translation else ()))
    table = Table(title=title)
    table.add_column("System")
    table.add_column("Accuracy over")
    table.add_column("N", justify="right")
    for key in keys:
        heading = key.capitalize() + (" (not in overall)" if key in EXCLUDED_FROM_OVERALL else "")
        table.add_column(heading, justify="right")
    for summary in summaries:
        for label, attribute in DENOMINATORS:
            scores = getattr(summary, attribute)
            table.add_row(
                summary.system,
                label,
                str(scores.get(OVERALL, Score()).count),
                *(percent(scores.get(key, Score())) for key in keys),
            )
    return table


def _counted(counter) -> str:
    return ", ".join(f"{name} ({count})" for name, count in counter.most_common()) or NOT_APPLICABLE


def models_table(summaries: Sequence[MindCubeSummary], title: str = "Models (items)") -> Table:
    """Which model wrote the programs and which answered, with counts; fallbacks are counted, not
    hidden: programs the offline planner wrote because the code model failed, and answers from the
    photos alone because no program ran."""
    table = Table(title=title)
    for name in ("System", "Code model", "Answer model", "Planner fallbacks", "Images-only answers"):
        table.add_column(name, justify="right" if name.endswith(("fallbacks", "answers")) else "left")
    for summary in summaries:
        table.add_row(
            summary.system,
            _counted(summary.code_models),
            _counted(summary.answer_models),
            str(summary.code_fallbacks),
            str(summary.images_only),
        )
    return table


def pipeline_table(
    summaries: Sequence[MindCubeSummary | Omni3DSummary],
    title: str = "Pipeline: success (%) and mean time per stage (ms)",
) -> Table:
    """Parse success (a program was produced), execution success (it ran), answer success, errors
    (failed requests) and mean time per stage. Rates are over the requests that came back; "-" where
    a stage does not apply (the baseline has no program)."""
    table = Table(title=title)
    table.add_column("System")
    for name in ("Parsed", "Ran", "Answered", "Errors"):
        table.add_column(name, justify="right")
    for stage in STAGES:
        table.add_column(STAGE_HEADINGS.get(stage, stage), justify="right")
    for summary in summaries:
        parsed = getattr(summary, "parse_success", Score())
        executed = getattr(summary, "execution_success", Score())
        table.add_row(
            summary.system,
            percent(parsed),
            percent(executed),
            percent(summary.answer_success),
            str(summary.errors),
            *(milliseconds(summary.mean_ms.get(stage)) for stage in STAGES),
        )
    return table


def mindcube_report(summaries: Sequence[MindCubeSummary], title: str = "MindCube accuracy (%)") -> Group:
    return Group(
        mindcube_accuracy_table(summaries, title), models_table(summaries), pipeline_table(summaries)
    )


def omni3d_table(summaries: Sequence[Omni3DSummary], title: str = "Omni3D-Bench (%)") -> Table:
    """Exact-match accuracy for yes/no, multiple choice and counts; MRA for other numbers."""
    table = Table(title=title)
    table.add_column("System")
    table.add_column("N", justify="right")
    headings = {"yes/no": "Yes/No", "multiple choice": "Multi-choice", "count": "Count", "numeric": "MRA"}
    for kind in OMNI3D_KINDS:
        table.add_column(f"{headings[kind]} (n)", justify="right")
    for summary in summaries:
        table.add_row(
            summary.system,
            str(summary.count),
            *(f"{percent(summary.by_kind[kind])} ({summary.by_kind[kind].count})" for kind in OMNI3D_KINDS),
        )
    return table


def omni3d_report(summaries: Sequence[Omni3DSummary], title: str = "Omni3D-Bench (%)") -> Group:
    return Group(omni3d_table(summaries, title), pipeline_table(summaries))


def mmsi_table(summary, title: str | None = None) -> Table:
    """MMSI-Bench per question type: both extractors' accuracy, answered / refused / errors, wall time."""
    mode = "circular" if summary.circular else "plain"
    table = Table(title=title or f"MMSI-Bench accuracy (%), {mode} scoring: {summary.system}")
    for heading in (
        "Type",
        "N",
        "Accuracy",
        "Published extraction",
        "Answered",
        "Refused",
        "Errors",
        "Wall s",
    ):
        table.add_column(heading, justify="left" if heading == "Type" else "right")
    for name, row in summary.rows.items():
        table.add_row(
            name,
            str(row.accuracy.count),
            percent(row.accuracy),
            percent(row.published),
            str(row.answered),
            str(row.refused),
            str(row.errors),
            f"{row.wall_s:.1f}",
        )
    return table
