"""Progress on stderr: a spinner for work of unknown length, and a solve's stages as they happen."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator

from rich.progress import Progress, SpinnerColumn, TaskID, TextColumn, TimeElapsedColumn

from cli.console import errors
from shared.wire.schemas import StageEvent

MARKS = {"done": "[green]✓[/]", "failed": "[red]✗[/]"}


@contextlib.contextmanager
def spinner(description: str) -> Iterator[None]:
    # On stderr, so `--json` output on stdout stays clean; rich hides it when stderr is no terminal.
    columns = (SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn())
    with Progress(*columns, console=errors, transient=True, disable=not errors.is_terminal) as progress:
        progress.add_task(description, total=None)
        yield


@contextlib.contextmanager
def solve_stages() -> Iterator[Callable[[StageEvent], None]]:
    """A callback for `AgentClient.solve_with_progress`: one line per stage, updated in place.

    In a terminal each stage spins while it runs and keeps its last detail; elsewhere (logs, CI)
    each finished or failed stage is one plain line on stderr.
    """
    if not errors.is_terminal:

        def plain(event: StageEvent) -> None:
            if event.state != "started":
                at = f"{event.elapsed_ms / 1e3:.1f} s"
                errors.print(f"{event.stage} {event.state} at {at}: {event.detail}", soft_wrap=True)

        yield plain
        return
    columns = (SpinnerColumn(finished_text=""), TextColumn("{task.description}"))
    with Progress(*columns, console=errors) as progress:
        tasks: dict[str, TaskID] = {}

        def show(event: StageEvent) -> None:
            line = f"[bold]{event.stage}[/] [dim]{event.detail}[/]"
            if event.state != "started":
                line = f"{MARKS[event.state]} {line} [dim]({event.elapsed_ms / 1e3:.1f} s)[/]"
            if event.stage not in tasks:
                tasks[event.stage] = progress.add_task(line, total=1)
            progress.update(tasks[event.stage], description=line, completed=event.state != "started")

        yield show
