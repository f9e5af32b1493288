"""`pyspatial reconstruct`: upload images, reconstruct them, and summarize the cameras."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.table import Table

from cli.api_keys import recon_key_option
from cli.backbones import BACKBONE_HELP, check_backbone
from cli.console import console, fail, service_errors
from cli.images import collect_images
from cli.progress import spinner
from shared.wire.client import ReconClient
from shared.wire.schemas import ReconstructionSummary
from shared.wire.settings import DEFAULT_RECON_PORT

DEFAULT_RECON_URL = f"http://127.0.0.1:{DEFAULT_RECON_PORT}"


def show_summary(summary: ReconstructionSummary) -> None:
    console.print(
        f"[bold]scene[/] {summary.scene_id}  backbone {summary.backbone} ({summary.backbone_version})"
        + f"  units {summary.units}"
        + ("  [dim](cached)[/]" if summary.cached else "")
    )
    table = Table(title="cameras", header_style="bold")
    for column in ("view", "registered", "size", "focal (px)", "centre (x, y, z)"):
        table.add_column(column, justify="right")
    for camera in summary.cameras:
        centre = "-"
        if camera.extrinsic is not None:
            pose = np.asarray(camera.extrinsic)
            centre = ", ".join(f"{v:+.3f}" for v in -pose[:, :3].T @ pose[:, 3])
        table.add_row(
            str(camera.view),
            "yes" if camera.registered else "[red]no[/]",
            f"{camera.width}x{camera.height}",
            "-" if camera.intrinsic is None else f"{camera.intrinsic[0][0]:.1f} ({camera.intrinsics_source})",
            centre,
        )
    console.print(table)
    registered = sum(camera.registered for camera in summary.cameras)
    console.print(f"{registered} of {len(summary.cameras)} views registered, {summary.num_points} points")
    for warning in summary.warnings:
        console.print(f"[yellow]warning:[/] {warning}")
    timings = ", ".join(f"{name} {ms:.0f} ms" for name, ms in summary.timings_ms.items())
    console.print(f"[dim]timings: {timings or 'none reported'}[/]")


def reconstruct(
    images: list[Path] = typer.Argument(..., help="Image files, or one folder (sorted by name)."),
    backbone: str | None = typer.Option(None, help=BACKBONE_HELP),
    ply: Path | None = typer.Option(None, help="Also save the point cloud as a PLY file here."),
    recon_url: str = typer.Option(DEFAULT_RECON_URL, envvar="PYSPATIAL_RECON_URL", help="Recon service."),
    timeout: float = typer.Option(900.0, help="Seconds to wait for the reconstruction."),
    api_key: str | None = recon_key_option(),
) -> None:
    """Reconstruct a scene from images and print its cameras, points and warnings."""
    try:
        paths = collect_images(images)
    except ValueError as error:
        raise fail(str(error)) from None
    with service_errors("--api-key"), ReconClient(recon_url, timeout=timeout, api_key=api_key) as client:
        check_backbone(client.backbones(), backbone)
        with spinner(f"uploading {len(paths)} images to {recon_url}"):
            scene = client.upload_scene(paths)
        with spinner(f"reconstructing scene {scene.scene_id}"):
            summary = client.reconstruct(scene.scene_id, backbone)
        show_summary(summary)
        if ply is not None:
            with spinner("downloading the point cloud"):
                ply.write_bytes(client.ply(scene.scene_id, backbone or summary.backbone))
            console.print(f"point cloud saved to {ply}")
