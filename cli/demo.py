"""`pyspatial demo`: start both services locally, solve the bundled example, compare the answer."""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np
import typer

from cli.api_keys import sibling_recon_env, started_services_key
from cli.console import console, fail, service_errors
from cli.local_stack import (
    ServiceProcess,
    StackError,
    free_port,
    interrupt_on_signals,
    start_service,
    stop_all,
    wait_ready,
)
from cli.progress import solve_stages, spinner
from cli.results import save_clue_images, show_solution
from shared.geometry.poses import rotate_right
from shared.wire.client import AgentClient, ReconClient

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_EXAMPLE = REPO_ROOT / "examples" / "living_room"


def load_example(folder: Path) -> tuple[dict, list[Path]]:
    spec_path = folder / "example.json"
    if not spec_path.is_file():
        raise ValueError(f"no example.json in {folder} (run scripts/make_example.py)")
    spec = json.loads(spec_path.read_text())
    images = [folder / name for name in spec["images"]]
    missing = [str(path) for path in images if not path.is_file()]
    if missing:
        raise ValueError(f"example images missing: {', '.join(missing)}")
    return spec, images


def demo_environment(data_dir: Path) -> dict[str, str]:
    """Settings of the demo's services: in-process cache, classical backbone, a throwaway store.

    Model variables (PYSPATIAL_CODE_MODEL, ...) pass through from this environment, so the demo
    uses real models when they are configured and the offline planner/answerer otherwise.
    """
    return {
        "REDIS_URL": "",  # empty wins over a .env file and means "no Redis": the in-process cache
        "PYSPATIAL_REDIS_URL": "",
        "PYSPATIAL_BACKBONE": "classical",
        "PYSPATIAL_DATA_DIR": str(data_dir),
    }


def start_stack(log_dir: Path, data_dir: Path) -> tuple[list[ServiceProcess], dict, dict]:
    """Recon then agent on free loopback ports; returns the processes and both /readyz bodies."""
    env = demo_environment(data_dir)
    services: list[ServiceProcess] = []
    try:
        recon = start_service("recon", free_port(), env=env, log_path=log_dir / "recon.log")
        services.append(recon)
        with spinner(f"starting the reconstruction service at {recon.url}"):
            recon_ready = wait_ready(recon, timeout=180.0)
        agent_env = {**env, "PYSPATIAL_RECON_URL": recon.url, **sibling_recon_env()}
        agent = start_service("agent", free_port(), env=agent_env, log_path=log_dir / "agent.log")
        services.append(agent)
        with spinner(f"starting the agent service at {agent.url}"):
            agent_ready = wait_ready(agent, timeout=120.0)
    except BaseException:
        stop_all(services)
        raise
    return services, recon_ready, agent_ready


def render_turned_view(client: ReconClient, scene_id: str, out_dir: Path) -> Path:
    """Show the renderer too: view 1 of the reconstruction, turned right in place by 30 degrees."""
    summary = client.reconstruct(scene_id)  # cached by the solve that just ran
    first = summary.cameras[0]
    if first.extrinsic is None:
        raise fail("view 1 was not registered, so there is no pose to render from", 1)
    pose = rotate_right(np.asarray(first.extrinsic), 30.0, up=np.asarray(summary.up))
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "view_1_turned_right_30.png"
    path.write_bytes(client.render(scene_id, pose, width=first.width, height=first.height))
    return path


def demo(
    out: Path = typer.Option(Path("pyspatial-out") / "demo", help="Folder for clue images and logs."),
    example: Path = typer.Option(DEFAULT_EXAMPLE, help="Example folder with example.json and images."),
    keep_running: bool = typer.Option(False, "--keep-running", help="Leave the services up until Ctrl-C."),
) -> None:
    """Run the whole system locally on the bundled example (no Redis, no models needed)."""
    try:
        spec, images = load_example(example)
    except ValueError as error:
        raise fail(str(error)) from None
    console.print(f"[bold]question:[/] {spec['question']}")
    console.print(f"[bold]images:[/] {', '.join(str(path) for path in images)}")
    log_dir = out / "logs"
    with tempfile.TemporaryDirectory(prefix="pyspatial-demo-") as data_dir:
        try:
            services, recon_ready, agent_ready = start_stack(log_dir, Path(data_dir))
        except StackError as error:
            raise fail(str(error), 1) from None
        try:
            console.print(
                f"services up: backbone {recon_ready['backbone']}, cache {recon_ready['cache']}, "
                f"code model {agent_ready['code_model']}, answer model {agent_ready['answer_model']} "
                f"[dim](logs in {log_dir})[/]"
            )
            agent = services[1]
            key = started_services_key()  # PYSPATIAL_API_KEYS in this environment guard both services
            if key:
                console.print("PYSPATIAL_API_KEYS is set, so both services demand a key: the demo sends one")
            with service_errors(), AgentClient(agent.url, timeout=600.0, api_key=key) as client:
                with solve_stages() as on_stage:
                    result = client.solve_with_progress(spec["question"], images=images, on_stage=on_stage)
            saved = save_clue_images(result, out / result.scene_id)
            show_solution(result, saved)
            with service_errors(), ReconClient(services[0].url, timeout=600.0, api_key=key) as recon:
                novel = render_turned_view(recon, result.scene_id, out / result.scene_id)
            console.print(f"novel view (view 1 turned 30 degrees right, rendered from the points): {novel}")
            expected = spec["expected_answer"]
            correct = result.answer == expected
            verdict = "[bold green]correct[/]" if correct else "[bold red]wrong[/]"
            console.print(f"expected {expected}, got {result.answer}: {verdict}")
            if keep_running:
                console.print(f"services still running: recon {services[0].url}, agent {agent.url}")
                console.print(f"[bold]web page:[/] {agent.url}/ (open it in a browser)")
                console.print("try: pyspatial solve examples/living_room -q '...' --agent-url " + agent.url)
                console.print("Ctrl-C stops them.")
                _wait_for_interrupt(services)
            else:
                console.print("web page: run `pyspatial demo --keep-running` and open the agent's URL")
            if not correct:
                raise typer.Exit(1)
        finally:
            with spinner("stopping the services"):
                stop_all(services)


def _wait_for_interrupt(services: list[ServiceProcess]) -> None:
    try:
        with interrupt_on_signals():
            while all(service.alive() for service in services):
                time.sleep(0.5)
    except KeyboardInterrupt:
        console.print("stopping ...")
