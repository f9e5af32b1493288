"""Show a SolveResponse to a person, and save its clue images as PNG files."""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np
from rich.panel import Panel
from rich.syntax import Syntax
from rich.table import Table

from cli.console import console
from shared.wire.schemas import ClueView, SolveResponse


def default_output_dir(scene_id: str) -> Path:
    return Path("pyspatial-out") / scene_id


def save_clue_images(result: SolveResponse, out_dir: Path) -> list[Path]:
    """Decode the clue's base64 PNGs into out_dir/clue_1.png, clue_2.png, ..."""
    if not result.clue.images:
        return []
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for number, encoded in enumerate(result.clue.images, start=1):
        path = out_dir / f"clue_{number}.png"
        path.write_bytes(base64.b64decode(encoded))
        paths.append(path)
    return paths


def show_solution(result: SolveResponse, saved_images: list[Path]) -> None:
    models = f"code: {result.code_model} · answer: {result.answer_model} · backbone: {result.backbone}"
    console.print(f"[bold]scene[/] {result.scene_id}  [dim]{models}[/]")
    if result.program:
        tries = len(result.attempts)
        title = f"program (attempt {tries} of {tries})" if tries > 1 else "program"
        code = Syntax(result.program, "python", line_numbers=True, word_wrap=True)
        console.print(Panel(code, title=title, expand=False))
    else:
        console.print("[yellow]no program ran successfully[/]")
    if result.fallback:
        kind = result.fallback.replace("_", " ")
        console.print(f"[bold yellow]fallback ({kind}):[/] {result.fallback_reason}")
    if result.code_model_fallback:
        console.print(f"[yellow]fallback:[/] {result.code_model_fallback}")
    for number, attempt in enumerate(result.attempts, start=1):
        if attempt.error:
            console.print(f"[dim]attempt {number} failed:[/] {attempt.error.strip().splitlines()[-1]}")
        if attempt.dropped:
            console.print(f"[dim]attempt {number}: dropped {len(attempt.dropped)} line(s) of demo code[/]")
    clue = result.clue.text.strip() if result.clue.text else "(no text)"
    console.print(Panel(clue, title="clue", expand=False))
    for path, view in zip(saved_images, result.clue.views or [None] * len(saved_images), strict=False):
        console.print(f"clue image: {path}{_origin(view)}")
    for note in result.clue.notes:
        console.print(f"[yellow]note:[/] {note}")
    if result.answer:
        console.print(f"[bold green]answer: {result.answer}[/]")
    else:
        console.print(f"[bold yellow]no answer[/]: {result.answer_reason or 'the answerer gave none'}")
    if result.reasoning:
        console.print(f"[dim]reasoning:[/] {result.reasoning}")
    show_timings(result)


def _origin(view: ClueView | None) -> str:
    """Where a clue image came from, e.g. ' (rendered from a camera at (0.1, 1.4, -2.0))'."""
    if view is None:
        return ""
    if view.source == "input":
        return f" (input image {view.input_view})" if view.input_view is not None else ""
    if view.extrinsic is None:
        return " (rendered)"
    pose = np.asarray(view.extrinsic)
    centre = -pose[:, :3].T @ pose[:, 3]
    return f" (rendered from a camera at ({', '.join(f'{v:.2f}' for v in centre)}))"


def show_timings(result: SolveResponse) -> None:
    table = Table(title="timings (ms)", show_header=True, header_style="bold")
    for column in ("reconstruction", "codegen", "execution", "answering", "total"):
        table.add_column(column, justify="right")
    timings = result.timings
    values = (
        timings.reconstruction_ms,
        timings.codegen_ms,
        timings.execution_ms,
        timings.answering_ms,
        timings.total_ms,
    )
    table.add_row(*(f"{value:.0f}" for value in values))
    console.print(table)
