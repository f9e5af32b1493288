"""Every fault its own status at the services' edge: the drain, a hanging or resetting recon.

Real processes started as the containers start them (the Dockerfile's CMD), real TCP servers that
misbehave (tests/support/misbehaving.py).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time

import httpx
import pytest

from shared.wire.client import ReconClient, RetryPolicy, ServiceError, ServiceUnreachable
from tests.support.misbehaving import MisbehavingServer, flaky, hang
from tests.support.processes import REPO_ROOT, free_port, running_service
from tests.support.stack import recon_env
from tests.test_compose import dockerfile_command

RECON_APP = "services.recon.app:create_app"


def container_command(name: str, port: int) -> list[str]:
    """The Dockerfile's CMD with the console script run by this interpreter, on a free port."""
    command = dockerfile_command(REPO_ROOT / "services" / name / "Dockerfile")
    assert command[0] == "pyspatial"
    command = [sys.executable, "-m", "cli.main", *command[1:]]
    command[command.index(f"--{name}-port") + 1] = str(port)
    command[command.index("--host") + 1] = "127.0.0.1"
    return command


def wait_healthy(url: str, process: subprocess.Popen, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        assert process.poll() is None, process.stdout.read().decode(errors="replace")
        with contextlib.suppress(httpx.HTTPError):
            if httpx.get(url + "/healthz", timeout=1.0).status_code == 200:
                return
        time.sleep(0.1)
    raise AssertionError(f"{url} did not become healthy")


def test_the_container_entry_point_drains_and_a_cut_off_request_gets_a_503(tmp_path):
    stopped = threading.Event()
    with MisbehavingServer(hang(stopped)) as recon:
        port = free_port()
        env = {**os.environ, "PYSPATIAL_RECON_URL": recon.url, "PYSPATIAL_DRAIN_S": "1"}
        process = subprocess.Popen(
            container_command("agent", port), cwd=tmp_path, env=env,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        )
        try:
            url = f"http://127.0.0.1:{port}"
            wait_healthy(url, process)
            answers: list[httpx.Response] = []
            body = {"question": "Which way did I move? A. left B. right", "scene_id": "a" * 24}
            solve = threading.Thread(
                target=lambda: answers.append(httpx.post(url + "/v1/solve", json=body, timeout=60))
            )
            solve.start()
            deadline = time.monotonic() + 30
            while recon.connections == 0:  # the solve is waiting on recon, which never answers
                assert time.monotonic() < deadline and not answers, answers
                time.sleep(0.05)
            started = time.monotonic()
            process.send_signal(signal.SIGTERM)
            solve.join(timeout=30)
            assert process.wait(timeout=30) in (0, -signal.SIGTERM)  # uvicorn re-raises the signal
            exited_s = time.monotonic() - started
        finally:
            stopped.set()
            if process.poll() is None:
                process.kill()
                process.wait()
    (cut_off,) = answers
    assert cut_off.status_code == 503, cut_off.text
    assert cut_off.headers["retry-after"] == "1" and "shutting down" in cut_off.json()["detail"]
    assert exited_s < 1 + 5, exited_s  # PYSPATIAL_DRAIN_S, not the recon timeout (600 s)


# ---- the agent's recon client retries what is safe to retry ---------------------------------------


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    with running_service(RECON_APP, recon_env(tmp_path_factory.mktemp("recon"), redis_url)) as service:
        yield service


def recon_port(recon) -> int:
    return int(recon.url.rsplit(":", 1)[1])


def test_recon_calls_are_retried_through_resets_and_503s(recon):
    with MisbehavingServer(flaky(recon_port(recon), ["reset", "503", "reset"])) as proxy:
        retry = RetryPolicy(attempts=4, backoff_base_s=0.05)
        with ReconClient(proxy.url, timeout=10, retry=retry) as client:
            menu = client.backbones()
    assert "classical" in str(menu) and proxy.connections == 4  # three failures, then the real recon


def test_retries_stop_at_the_attempts_and_the_window(recon):
    with MisbehavingServer(flaky(recon_port(recon), ["503"] * 10)) as proxy:
        with ReconClient(proxy.url, timeout=10, retry=RetryPolicy(attempts=3, backoff_base_s=0.05)) as client:
            with pytest.raises(ServiceError) as refused:
                client.backbones()
        assert refused.value.status_code == 503 and proxy.connections == 3
    with MisbehavingServer(flaky(recon_port(recon), ["reset"] * 10)) as proxy:
        retry = RetryPolicy(attempts=10, backoff_base_s=0.3, window_s=0.5)
        with ReconClient(proxy.url, timeout=10, retry=retry) as client:
            started = time.monotonic()
            with pytest.raises(ServiceUnreachable):
                client.backbones()
        assert time.monotonic() - started < 0.5 + 1 and proxy.connections < 10  # the window, not 10 tries


def test_a_refusal_is_not_retried(recon):
    with MisbehavingServer(flaky(recon_port(recon), [])) as proxy:
        with ReconClient(proxy.url, timeout=10, retry=RetryPolicy(attempts=3)) as client:
            with pytest.raises(ServiceError) as missing:
                client.scene_info("0" * 24)
    assert missing.value.status_code == 404 and proxy.connections == 1
