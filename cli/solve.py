"""`pyspatial solve`: ask the agent service a question about some images."""

from __future__ import annotations

from pathlib import Path

import typer

from cli.api_keys import agent_key_option
from cli.backbones import BACKBONE_HELP, check_backbone
from cli.console import fail, service_errors
from cli.images import collect_images
from cli.progress import solve_stages
from cli.results import default_output_dir, save_clue_images, show_solution
from shared.wire.client import AgentClient
from shared.wire.settings import DEFAULT_AGENT_PORT

DEFAULT_AGENT_URL = f"http://127.0.0.1:{DEFAULT_AGENT_PORT}"


def solve(
    images: list[Path] = typer.Argument(None, help="Image files, or one folder (sorted by name)."),
    question: str = typer.Option(..., "--question", "-q", help="The question, with its options."),
    scene_id: str | None = typer.Option(None, help="A scene already uploaded (instead of IMAGES)."),
    backbone: str | None = typer.Option(None, help=BACKBONE_HELP),
    agent_url: str = typer.Option(DEFAULT_AGENT_URL, envvar="PYSPATIAL_AGENT_URL", help="Agent service."),
    out: Path | None = typer.Option(None, help="Folder for clue images [default: pyspatial-out/SCENE]."),
    as_json: bool = typer.Option(False, "--json", help="Print only the SolveResponse JSON."),
    timeout: float = typer.Option(900.0, help="Seconds to wait for the answer."),
    api_key: str | None = agent_key_option(),
) -> None:
    """Answer a spatial question: the agent writes a program, runs it, and answers."""
    paths: list[Path] = []
    if images:
        try:
            paths = collect_images(images)
        except ValueError as error:
            raise fail(str(error)) from None
    elif not scene_id:
        raise fail("give IMAGES or --scene-id")
    with service_errors(), AgentClient(agent_url, timeout=timeout, api_key=api_key) as client:
        if backbone is not None:
            check_backbone(client.backbones(), backbone)
        with solve_stages() as on_stage:
            result = client.solve_with_progress(
                question, images=paths or None, scene_id=scene_id, backbone=backbone, on_stage=on_stage
            )
    if as_json:
        print(result.model_dump_json(indent=2))
        return
    saved = save_clue_images(result, out or default_output_dir(result.scene_id))
    show_solution(result, saved)
