"""Run the two services as real child processes on this machine (for `serve all` and `demo`)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Literal

import httpx

from shared.local.services import free_port  # noqa: F401  (re-exported for cli.demo)

ServiceName = Literal["recon", "agent"]


class StackError(RuntimeError):
    """A service process exited or did not become ready; the message names its log."""


def reachable_host(host: str) -> str:
    """The address a client on this machine uses for a server bound to `host`."""
    return "127.0.0.1" if host in ("0.0.0.0", "", "::") else host


@dataclass
class ServiceProcess:
    name: ServiceName
    url: str
    process: subprocess.Popen
    log_path: Path | None  # None when the output goes to this terminal

    def log_tail(self, lines: int = 20) -> str:
        if self.log_path is None or not self.log_path.exists():
            return ""
        return "\n".join(self.log_path.read_text(errors="replace").splitlines()[-lines:])

    def alive(self) -> bool:
        return self.process.poll() is None

    def stop(self, timeout: float = 15.0) -> None:
        """SIGTERM (uvicorn shuts down gracefully), then SIGKILL if it hangs."""
        if not self.alive():
            return
        self.process.send_signal(signal.SIGTERM)
        try:
            self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait(timeout=5)


def start_service(
    name: ServiceName,
    port: int,
    host: str = "127.0.0.1",
    env: dict[str, str] | None = None,
    log_path: Path | None = None,
) -> ServiceProcess:
    """Start `pyspatial serve NAME` as a child process; it runs uvicorn with the app factory."""
    port_option = "--recon-port" if name == "recon" else "--agent-port"
    # -P keeps the current folder off sys.path, so a stray ./cli or ./bench cannot shadow ours.
    isolate = ["-P"] if sys.version_info >= (3, 11) else []
    command = [sys.executable, *isolate, "-m", "cli.main", "serve", name, "--host", host, port_option]
    command.append(str(port))
    output: IO | int | None = None
    if log_path is not None:
        log_path.parent.mkdir(parents=True, exist_ok=True)
        output = log_path.open("wb")
    process = subprocess.Popen(
        command,
        env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})},
        stdout=output,
        stderr=subprocess.STDOUT if output is not None else None,
    )
    if output is not None:
        output.close()  # the child holds its own handle
    return ServiceProcess(name, f"http://{reachable_host(host)}:{port}", process, log_path)


def wait_ready(service: ServiceProcess, timeout: float = 120.0, path: str = "/readyz") -> dict:
    """Poll `path` until it answers 200; return its JSON body. Raise StackError on exit or timeout."""
    deadline = time.monotonic() + timeout
    last = "no answer yet"
    while time.monotonic() < deadline:
        if not service.alive():
            raise StackError(_died(service, f"exited with code {service.process.returncode}"))
        with contextlib.suppress(httpx.HTTPError):
            response = httpx.get(service.url + path, timeout=2.0)
            if response.status_code == 200:
                return response.json()
            last = f"{path} answered {response.status_code}: {response.text[:200]}"
        time.sleep(0.2)
    raise StackError(_died(service, f"was not ready after {timeout:.0f} s ({last})"))


def _died(service: ServiceProcess, what: str) -> str:
    where = f"; log: {service.log_path}" if service.log_path else ""
    tail = service.log_tail(8)
    return f"the {service.name} service {what}{where}" + (f"\n{tail}" if tail else "")


@contextlib.contextmanager
def interrupt_on_signals() -> Iterator[None]:
    """SIGINT and SIGTERM raise KeyboardInterrupt here, even where SIGINT was inherited as ignored
    (a background job of a script), so the children are always stopped by us, cleanly."""

    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    previous = {number: signal.signal(number, interrupt) for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def stop_all(services: list[ServiceProcess]) -> None:
    """Stop in reverse start order (the agent before the recon service it calls)."""
    for service in reversed(services):
        service.stop()
