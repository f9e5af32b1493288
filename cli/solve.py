"""`pyspatial solve`: ask the agent service a question about some images.

Without `--agent-url` (or PYSPATIAL_AGENT_URL) it starts the local stack itself, as `pyspatial demo`
does (recon and agent on free loopback ports, in-process cache, classical backbone, models from the
environment when set), says so, and stops it after the answer.
"""

from __future__ import annotations

import contextlib
import tempfile
from collections.abc import Iterator
from pathlib import Path

import typer

from cli.api_keys import agent_key_option
from cli.backbones import BACKBONE_HELP, check_backbone
from cli.console import console, fail, service_errors
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
    agent_url: str | None = typer.Option(
        None,
        envvar="PYSPATIAL_AGENT_URL",
        help=f"Agent service (e.g. {DEFAULT_AGENT_URL}) [default: start a local stack, stop it after].",
    ),
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
    if agent_url is None and scene_id:
        raise fail("--scene-id names a scene of a running agent: give its --agent-url too")
    with _agent(agent_url, quiet=as_json) as (url, local_key):
        key = api_key or local_key
        with service_errors(), AgentClient(url, timeout=timeout, api_key=key) as client:
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


@contextlib.contextmanager
def _agent(agent_url: str | None, quiet: bool) -> Iterator[tuple[str, str | None]]:
    """(the agent's URL, the key the started services demand): the given agent, else a local stack."""
    if agent_url is not None:
        yield agent_url, None
        return
    from cli.api_keys import started_services_key
    from cli.demo import start_stack
    from cli.local_stack import StackError, stop_all

    say = console.print if not quiet else (lambda text: typer.echo(text, err=True))
    out = Path("pyspatial-out") / "solve"
    with tempfile.TemporaryDirectory(prefix="pyspatial-solve-") as data_dir:
        say(f"no --agent-url: starting the local stack (recon + agent; logs in {out / 'logs'})")
        try:
            services, _, agent_ready = start_stack(out / "logs", Path(data_dir))
        except StackError as error:
            raise fail(str(error), 1) from None
        try:
            say(f"local stack up at {services[1].url}, code model {agent_ready['code_model']}")
            yield services[1].url, started_services_key()
        finally:
            stop_all(services)
            say("local stack stopped")
