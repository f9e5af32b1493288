"""`pyspatial weights pull|list|verify`: the learned backbones' published checkpoints in one command.

Files go to the Hugging Face hub cache (HF_HOME / HF_HUB_CACHE); the recon service finds them
there by itself. HF_ENDPOINT and HF_HUB_OFFLINE work as huggingface_hub defines them.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from cli.console import EXIT_SERVICE_ERROR, console, errors, fail
from services.recon.checkpoints import (
    CATALOGUE,
    WeightsError,
    locate,
    published,
    pull,
    remove_from_cache,
    verify,
)
from shared.wire.settings import ReconSettings

weights_app = typer.Typer(
    help="Download, list and check the checkpoints of vggt, pi3 and pi3x (Pi3X is the paper's backbone).",
    no_args_is_help=True,
)
NAMES = ", ".join(CATALOGUE)


def _settings_paths(name: str, settings: ReconSettings) -> tuple[str | None, str | None]:
    """(explicit checkpoint, config) the recon service would use for this backbone."""
    checkpoint = getattr(settings, f"{name}_checkpoint")
    config = getattr(settings, f"{name}_config")
    return (str(checkpoint) if checkpoint else None, str(config) if config else None)


def _size(path: Path) -> str:
    size = path.stat().st_size
    for unit in ("B", "KB", "MB", "GB"):
        if size < 1000 or unit == "GB":
            return f"{size:.0f} {unit}" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1000.0
    return f"{size:.1f} GB"


def _checked_name(name: str) -> str:
    if name not in CATALOGUE:
        raise fail(f"unknown backbone {name!r}: choose one of {NAMES}")
    return name


@weights_app.command("pull")
def pull_command(
    name: str = typer.Argument(..., help=f"Which checkpoint: {NAMES}."),
    revision: str = typer.Option("main", help="Hub revision: a branch, tag or commit hash."),
) -> None:
    """Download a backbone's published checkpoint into the hub cache (resumes a dropped download)."""
    entry = published(_checked_name(name))
    settings = ReconSettings()
    errors.print(f"pulling {entry.repo_id} {entry.filename} (revision {revision})")
    try:
        path = pull(name, revision)
        problems = verify(name, path, _settings_paths(name, settings)[1])
    except WeightsError as error:
        raise fail(str(error), EXIT_SERVICE_ERROR) from None
    if problems:
        remove_from_cache(path)
        raise fail(
            f"{entry.repo_id} {entry.filename} does not fit the {name} architecture, so it was removed "
            "from the cache: " + "; ".join(problems),
            EXIT_SERVICE_ERROR,
        )
    console.print(f"{name}: {path} ({_size(path)}), tensors match the architecture", soft_wrap=True)
    if revision != settings.weights_revision:
        console.print(
            f"the recon service uses revision {settings.weights_revision}: set PYSPATIAL_WEIGHTS_REVISION"
        )


@weights_app.command("list")
def list_command() -> None:
    """Show, per backbone, its repository, whether its file is present, its size and path."""
    settings = ReconSettings()
    table = Table(header_style="bold")
    for column in ("backbone", "repository", "file", "present", "size", "path"):
        table.add_column(column, overflow="fold")
    for name, entry in CATALOGUE.items():
        path, found = locate(name, _settings_paths(name, settings)[0], settings.weights_revision)
        present = "yes" if path is not None else "[red]no[/]"
        table.add_row(
            name,
            entry.repo_id,
            entry.filename,
            present,
            _size(path) if path else "-",
            str(path) if path else found.replace("weights not present: ", ""),
        )
    console.print(table)


@weights_app.command("verify")
def verify_command(
    name: str = typer.Argument(..., help=f"Which checkpoint: {NAMES}."),
    path: Path | None = typer.Option(
        None, help="A checkpoint file (default: the one the service would use)."
    ),
) -> None:
    """Check a checkpoint's tensor names and shapes against the architecture, without loading it."""
    settings = ReconSettings()
    explicit, config = _settings_paths(_checked_name(name), settings)
    found, how = (path, f"--path {path}") if path else locate(name, explicit, settings.weights_revision)
    if found is None or not Path(found).is_file():
        raise fail(how if found is None else f"{found} does not exist", EXIT_SERVICE_ERROR)
    if Path(found).suffix.lower() != ".safetensors":
        console.print(
            f"[dim]{Path(found).name} is a pickled state dict: verifying it loads it (memory-mapped)[/]"
        )
    try:
        problems = verify(name, found, config)
    except WeightsError as error:
        raise fail(str(error), EXIT_SERVICE_ERROR) from None
    if problems:
        raise fail(
            f"{found} does not fit the {name} architecture: " + "; ".join(problems), EXIT_SERVICE_ERROR
        )
    console.print(f"{name}: {found} fits the architecture ({how})", soft_wrap=True)
