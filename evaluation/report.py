"""Tables of results, laid out as the pySpatial paper reports them (rich tables for the terminal).

Two tables per benchmark keep each within a terminal's width: the paper's accuracy table, and the
pipeline table (how often each stage succeeded, mean milliseconds per stage).
"""

from __future__ import annotations

from collections.abc import Sequence

from rich.console import Console, Group
from rich.table import Table

from evaluation.dataset import MINDCUBE_SETTINGS
from evaluation.metrics import OMNI3D_KINDS, STAGES, MindCubeSummary, Omni3DSummary, Score

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


def mindcube_accuracy_table(
    summaries: Sequence[MindCubeSummary], title: str = "MindCube accuracy (%)"
) -> Table:
    """The paper's table: one row per system, accuracy overall and per setting."""
    table = Table(title=title)
    table.add_column("System")
    table.add_column("N", justify="right")
    for name in ("Overall", *(s.capitalize() for s in MINDCUBE_SETTINGS)):
        table.add_column(name, justify="right")
    for summary in summaries:
        table.add_row(
            summary.system,
            str(summary.count),
            *(percent(summary.accuracy.get(key, Score())) for key in ("overall", *MINDCUBE_SETTINGS)),
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
    return Group(mindcube_accuracy_table(summaries, title), pipeline_table(summaries))


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
