"""`pyspatial synth`: render a synthetic question set (shared.synthetic.make_dataset)."""

from __future__ import annotations

from pathlib import Path

import typer

from cli.console import console
from cli.progress import spinner


def synth(
    out: Path = typer.Option(..., help="Output folder (images/, scenes/ and the JSONL file)."),
    scenes: int = typer.Option(8, min=1, help="Number of scenes."),
    seed: int = typer.Option(0, help="Seed: the same seed gives the same data set."),
    width: int = typer.Option(320, min=16),
    height: int = typer.Option(240, min=16),
) -> None:
    """Render procedural rooms with exact cameras and multiple-choice spatial questions."""
    from shared.synthetic import make_dataset  # open3d loads here, not for every command

    with spinner(f"rendering {scenes} scenes"):
        jsonl = make_dataset(out, scenes, seed, width, height)
    count = sum(1 for line in jsonl.read_text(encoding="utf-8").splitlines() if line.strip())
    console.print(f"{count} questions over {scenes} scenes written to {jsonl}")
