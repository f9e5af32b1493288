"""`pyspatial serve`: run the reconstruction service, the agent service, or both, with uvicorn."""

from __future__ import annotations

import enum
import logging
import os
import time

import typer

from cli.api_keys import sibling_recon_env
from cli.console import console, fail
from cli.local_stack import (
    ServiceProcess,
    StackError,
    interrupt_on_signals,
    reachable_host,
    start_service,
    stop_all,
    wait_ready,
)
from shared.wire.settings import DEFAULT_AGENT_PORT, DEFAULT_RECON_PORT, AgentSettings, ReconSettings

APP_FACTORIES = {
    "recon": "services.recon.app:create_app",
    "agent": "services.agent.app:create_app",
}


class Which(str, enum.Enum):
    recon = "recon"
    agent = "agent"
    all = "all"


def configure_logging() -> None:
    # The apps log what they use (backbone, cache, models) at WARNING when they start; a root
    # handler makes those lines, and INFO from pyspatial.*, show next to uvicorn's own.
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)-7s %(name)s: %(message)s")


def describe_configuration(which: str) -> str:
    """One line on what a service will use, read from the same settings the app reads."""
    if which == "recon":
        settings = ReconSettings()
        cache = f"Redis at {settings.redis_url}" if settings.redis_url else "in-process (REDIS_URL not set)"
        return f"backbone {settings.backbone}, cache {cache}, data in {settings.data_dir}"
    settings = AgentSettings()
    code = settings.code_model or "offline planner"
    answer = settings.answer_model or "offline answerer"
    return f"recon service {settings.recon_url}, code model {code}, answer model {answer}"


def run_one(which: str, host: str, port: int) -> None:
    """One service in this process: the entry point of `pyspatial serve` and of the containers."""
    import uvicorn

    configure_logging()
    console.print(f"[bold]{which} service[/] on http://{reachable_host(host)}:{port} (API docs at /docs)")
    console.print(f"  {describe_configuration(which)}")
    settings = ReconSettings() if which == "recon" else AgentSettings()
    uvicorn.run(
        APP_FACTORIES[which],
        factory=True,
        host=host,
        port=port,
        log_level="info",
        timeout_graceful_shutdown=max(1, round(settings.drain_s)),  # bounded SIGTERM drain
        # X-Forwarded-For is read by the app, from PYSPATIAL_TRUSTED_PROXIES only (shared/wire/access.py)
        proxy_headers=False,
    )


def run_both(host: str, recon_port: int, agent_port: int) -> None:
    """Recon and agent as two child processes sharing this terminal; Ctrl-C stops both."""
    services: list[ServiceProcess] = []
    try:
        with interrupt_on_signals():
            _start_and_watch(services, host, recon_port, agent_port)
    except StackError as error:
        raise fail(str(error), 1) from None
    except KeyboardInterrupt:
        console.print("stopping ...")
    finally:
        stop_all(services)


def _start_and_watch(services: list[ServiceProcess], host: str, recon_port: int, agent_port: int) -> None:
    recon_url = f"http://{reachable_host(host)}:{recon_port}"
    services.append(start_service("recon", recon_port, host))
    wait_ready(services[0], timeout=600.0, path="/healthz")
    agent_env = {"PYSPATIAL_RECON_URL": recon_url, **sibling_recon_env()}
    services.append(start_service("agent", agent_port, host, env=agent_env))
    wait_ready(services[1], timeout=120.0, path="/healthz")
    console.print(
        f"[bold green]ready[/]: recon {recon_url}, agent http://{reachable_host(host)}:{agent_port}"
        " (Ctrl-C stops both)"
    )
    while all(service.alive() for service in services):
        time.sleep(0.5)
    stopped = next(service for service in services if not service.alive())
    raise StackError(f"the {stopped.name} service exited with code {stopped.process.returncode}")


def serve(
    which: Which = typer.Argument(Which.all, help="recon, agent, or all (both as child processes)."),
    host: str = typer.Option("127.0.0.1", help="Address to bind (0.0.0.0 for every interface)."),
    recon_port: int = typer.Option(DEFAULT_RECON_PORT, help="Port of the reconstruction service."),
    agent_port: int = typer.Option(DEFAULT_AGENT_PORT, help="Port of the agent service."),
) -> None:
    """Run the services with uvicorn. Configuration comes from PYSPATIAL_* and REDIS_URL."""
    if which is Which.all:
        if "PYSPATIAL_RECON_URL" in os.environ:
            console.print("note: PYSPATIAL_RECON_URL is ignored by `serve all`; the agent uses its sibling")
        run_both(host, recon_port, agent_port)
    elif which is Which.recon:
        run_one("recon", host, recon_port)
    else:
        run_one("agent", host, agent_port)
