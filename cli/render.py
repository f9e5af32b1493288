"""`pyspatial render`: render a reconstructed scene from a given pose or a transformed input view."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import typer

from cli.api_keys import recon_key_option
from cli.console import console, fail, service_errors
from cli.progress import spinner
from cli.reconstruct import DEFAULT_RECON_URL
from shared.geometry import poses
from shared.wire.client import ReconClient


def parse_pose(text: str) -> np.ndarray:
    """A 3x4 or 4x4 extrinsic from 12 or 16 numbers (any separators, brackets allowed) or a JSON file."""
    path = Path(text).expanduser()
    if path.is_file():
        try:
            values = np.asarray(json.loads(path.read_text()), dtype=float).ravel()
        except (ValueError, TypeError) as error:
            raise ValueError(f"{path} does not hold a JSON list of numbers: {error}") from None
    else:
        tokens = [token for token in re.split(r"[\s,\[\]]+", text) if token]
        try:
            values = np.array([float(token) for token in tokens])
        except ValueError:
            raise ValueError(f"--pose is neither a file nor a list of numbers: {text!r}") from None
    if values.size not in (12, 16):
        raise ValueError(f"--pose needs 12 (3x4) or 16 (4x4) numbers, got {values.size}")
    return poses.validate_extrinsic(values.reshape(-1, 4))


def transform_pose(
    pose: np.ndarray,
    up: np.ndarray | None,
    turn_around: bool,
    rotate_left: float,
    rotate_right: float,
    move_forward: float,
    move_backward: float,
) -> np.ndarray:
    """Apply the pose tools in a fixed order: turn around, rotate left, rotate right, then move."""
    if turn_around:
        pose = poses.turn_around(pose, up=up)
    if rotate_left:
        pose = poses.rotate_left(pose, rotate_left, up=up)
    if rotate_right:
        pose = poses.rotate_right(pose, rotate_right, up=up)
    if move_forward:
        pose = poses.move_forward(pose, move_forward, up=up)
    if move_backward:
        pose = poses.move_backward(pose, move_backward, up=up)
    return pose


def render(
    scene_id: str = typer.Argument(..., help="Scene id printed by `pyspatial reconstruct`."),
    pose: str | None = typer.Option(None, help="12 or 16 numbers (3x4/4x4 world-to-camera) or a JSON file."),
    view: int | None = typer.Option(None, help="Start from input view K (1-based) instead of --pose."),
    rotate_left: float = typer.Option(0.0, help="Turn left by DEG degrees."),
    rotate_right: float = typer.Option(0.0, help="Turn right by DEG degrees."),
    move_forward: float = typer.Option(0.0, help="Move forward by D scene units."),
    move_backward: float = typer.Option(0.0, help="Move backward by D scene units."),
    turn_around: bool = typer.Option(False, "--turn-around", help="Face the opposite way."),
    width: int = typer.Option(512, min=16),
    height: int = typer.Option(512, min=16),
    zoom_out: float = typer.Option(0.5, help="Field-of-view widening, as the service's zoom_out."),
    backbone: str | None = typer.Option(None, help="Reconstruction to render (service default)."),
    out: Path = typer.Option(Path("render.png"), help="Where to write the PNG."),
    recon_url: str = typer.Option(DEFAULT_RECON_URL, envvar="PYSPATIAL_RECON_URL", help="Recon service."),
    api_key: str | None = recon_key_option(),
) -> None:
    """Render a novel view. Transforms apply in order: turn around, rotate left/right, move."""
    if (pose is None) == (view is None):
        raise fail("give exactly one of --pose and --view")
    with service_errors("--api-key"), ReconClient(recon_url, api_key=api_key) as client:
        up = None
        if view is not None:
            with spinner(f"reading the cameras of {scene_id}"):
                summary = client.reconstruct(scene_id, backbone)
            if not 1 <= view <= len(summary.cameras):
                raise fail(f"--view {view}: the scene has views 1..{len(summary.cameras)}")
            camera = summary.cameras[view - 1]
            if camera.extrinsic is None:
                raise fail(f"view {view} was not registered by the {summary.backbone} backbone", 1)
            start, up = np.asarray(camera.extrinsic), np.asarray(summary.up)
        else:
            try:
                start = parse_pose(pose)
            except ValueError as error:
                raise fail(str(error)) from None
        extrinsic = transform_pose(
            start, up, turn_around, rotate_left, rotate_right, move_forward, move_backward
        )
        with spinner("rendering"):
            png = client.render(
                scene_id, extrinsic, width=width, height=height, zoom_out=zoom_out, backbone=backbone
            )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(png)
    console.print(f"rendered {width}x{height} view saved to {out}")
    console.print(f"[dim]extrinsic (3x4): {np.round(extrinsic[:3], 4).tolist()}[/]")
