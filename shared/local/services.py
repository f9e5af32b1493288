"""Local processes: a throwaway Redis server and the services as uvicorn processes on free ports.

Used by `pyspatial demo`, the benchmarks and the tests, so all three run the real stack the same way.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx
import redis

REPO_ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def redis_answers(url: str) -> bool:
    try:
        return bool(redis.Redis.from_url(url, socket_timeout=0.5, socket_connect_timeout=0.5).ping())
    except redis.RedisError:
        return False


@dataclass
class RedisServer:
    url: str
    process: subprocess.Popen | None  # None when we borrowed a running server

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            self.process.wait(timeout=10)


def start_redis(port: int | None = None, extra_args: tuple[str, ...] = ()) -> RedisServer:
    """Start a throwaway redis-server (no persistence) on a free port and wait until it answers.

    `extra_args` go to redis-server as they are, e.g. ("--maxmemory", "6mb").
    """
    binary = shutil.which("redis-server")
    if binary is None:
        raise RuntimeError(
            "redis-server is not installed: run scripts/setup.sh (apt-get install redis-server)"
        )
    port = port or free_port()
    process = subprocess.Popen(
        [binary, "--port", str(port), "--bind", "127.0.0.1", "--save", "", "--appendonly", "no", *extra_args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"redis://127.0.0.1:{port}/0"
    deadline = time.monotonic() + 10
    while not redis_answers(url):
        if process.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"redis-server did not start on port {port}")
        time.sleep(0.05)
    return RedisServer(url=url, process=process)


@dataclass
class ServiceProcess:
    url: str
    process: subprocess.Popen
    log_path: Path

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=5)


def start_service(
    app: str,
    env: dict[str, str] | None = None,
    ready_path: str = "/healthz",
    timeout: float = 60.0,
    preexec_fn=None,
) -> ServiceProcess:
    """Run `uvicorn <app> --factory` as a real process and wait for `ready_path` to answer 200.

    `app` is an import string of an app factory, e.g. "services.recon.app:create_app".
    """
    port = free_port()
    log_file = tempfile.NamedTemporaryFile(prefix="service-", suffix=".log", delete=False)
    process_env = {**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})}
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "uvicorn",
            app,
            "--factory",
            "--host",
            "127.0.0.1",
            "--port",
            str(port),
            "--log-level",
            "warning",
            "--no-proxy-headers",  # X-Forwarded-For: the app's PYSPATIAL_TRUSTED_PROXIES, as in `serve`
            # SIGTERM: finish requests for at most this long, then stop (PYSPATIAL_DRAIN_S)
            "--timeout-graceful-shutdown",
            str(max(1, round(float(process_env.get("PYSPATIAL_DRAIN_S", "20"))))),
        ],
        cwd=REPO_ROOT,
        env=process_env,
        stdout=log_file,
        stderr=subprocess.STDOUT,
        preexec_fn=preexec_fn,  # e.g. resource limits for fault tests
    )
    service = ServiceProcess(url=f"http://127.0.0.1:{port}", process=process, log_path=Path(log_file.name))
    deadline = time.monotonic() + timeout
    while True:
        if process.poll() is not None:
            raise RuntimeError(f"{app} exited with {process.returncode}:\n{service.log()}")
        with contextlib.suppress(httpx.HTTPError):
            if httpx.get(service.url + ready_path, timeout=1.0).status_code == 200:
                return service
        if time.monotonic() > deadline:
            service.stop()
            raise RuntimeError(f"{app} did not become ready in {timeout}s:\n{service.log()}")
        time.sleep(0.1)


@contextlib.contextmanager
def running_service(app: str, env: dict[str, str] | None = None, **kwargs) -> Iterator[ServiceProcess]:
    service = start_service(app, env, **kwargs)
    try:
        yield service
    finally:
        service.stop()
