"""A spinner for work whose length is unknown (uploads, reconstructions, solves)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

from cli.console import errors


@contextlib.contextmanager
def spinner(description: str) -> Iterator[None]:
    # On stderr, so `--json` output on stdout stays clean; rich hides it when stderr is no terminal.
    columns = (SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn())
    with Progress(*columns, console=errors, transient=True, disable=not errors.is_terminal) as progress:
        progress.add_task(description, total=None)
        yield
