"""Every fault its own status at the services' edge: the drain, a hanging or resetting recon.

Real processes started as the containers start them (the Dockerfile's CMD), real TCP servers that
misbehave (tests/support/misbehaving.py).
"""

from __future__ import annotations

import base64
import contextlib
import io
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time

import httpx
import pytest
from PIL import Image

from shared.wire.client import ReconClient, RetryPolicy, ServiceError, ServiceUnreachable
from tests.support.misbehaving import MisbehavingServer, flaky, hang
from tests.support.processes import REPO_ROOT, free_port, running_service
from tests.support.stack import recon_env
from tests.test_compose import dockerfile_command

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
NO_SCENE = "/v1/scenes/" + "0" * 24


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
        output = process.stdout.read().decode(errors="replace") if process.stdout and process.poll() else ""
        assert process.poll() is None, output
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
            container_command("agent", port),
            cwd=tmp_path,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
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


def test_retries_stop_at_the_solves_deadline_before_their_own_window(recon):
    """A solve's client (`until`, as the pipeline makes one per solve) retries no later than its
    deadline, though the retry window and the attempts would allow many more tries."""
    # Resets (the 503s here ask for Retry-After: 0, so their tries are back to back, not spaced).
    for answers in (["reset"] * 20,):
        with MisbehavingServer(flaky(recon_port(recon), answers)) as proxy:
            retry = RetryPolicy(attempts=10, backoff_base_s=0.2, backoff_max_s=0.2, window_s=60)
            with ReconClient(proxy.url, timeout=10, retry=retry) as client:
                started = time.monotonic()
                with pytest.raises((ServiceError, ServiceUnreachable)):
                    client.until(started + 0.6).backbones()
                took = time.monotonic() - started
            assert took < 0.6 + 0.5 and 2 <= proxy.connections < 10, (answers[0], took, proxy.connections)
    with ReconClient(recon.url, timeout=10, retry=RetryPolicy(attempts=3)) as client:
        assert "classical" in str(client.until(time.monotonic() + 30).backbones())  # in time: answered
        with pytest.raises(ServiceUnreachable, match="deadline"):
            client.until(time.monotonic() - 1).backbones()  # past it: not even tried


def test_a_refusal_is_not_retried(recon):
    with MisbehavingServer(flaky(recon_port(recon), [])) as proxy:
        with ReconClient(proxy.url, timeout=10, retry=RetryPolicy(attempts=3)) as client:
            with pytest.raises(ServiceError) as missing:
                client.scene_info("0" * 24)
    assert missing.value.status_code == 404 and proxy.connections == 1


# ---- the agent's edge: bounded before the work starts -------------------------------------------

EDGE_LIMIT = 20_000_000  # bytes of one request, for these tests


@pytest.fixture(scope="module")
def edge_agent(tmp_path_factory):
    spool = tmp_path_factory.mktemp("spool")  # where the multipart parser spools files
    env = {
        "PYSPATIAL_RECON_URL": f"http://127.0.0.1:{free_port()}",  # refused before recon is asked
        "PYSPATIAL_MAX_REQUEST_BYTES": str(EDGE_LIMIT),
        "TMPDIR": str(spool),
    }
    with running_service(AGENT_APP, env) as agent:
        agent.spool = spool
        yield agent


def peak_rss_mb(pid: int) -> tuple[float, float]:
    """(current, peak) resident memory of a process, MB (VmRSS, VmHWM)."""
    fields = dict(line.split(":", 1) for line in open(f"/proc/{pid}/status").read().splitlines())
    return float(fields["VmRSS"].split()[0]) / 1024, float(fields["VmHWM"].split()[0]) / 1024


def _chunked_upload(url: str, total_bytes: int) -> tuple[bytes, int]:
    """A chunked multipart upload of `total_bytes` over a raw socket, stopped when the service
    answers; (the response, bytes of the body sent)."""
    host, port = url.removeprefix("http://").split(":")
    boundary = "edgeboundary"
    head = (
        f"POST /v1/solve HTTP/1.1\r\nHost: {host}\r\nTransfer-Encoding: chunked\r\n"
        f"Content-Type: multipart/form-data; boundary={boundary}\r\n\r\n"
    ).encode()
    part = (
        f'--{boundary}\r\nContent-Disposition: form-data; name="images"; filename="big.png"\r\n'
        "Content-Type: image/png\r\n\r\n"
    ).encode()
    chunk = b"\0" * (1 << 20)
    sent = 0
    with socket.create_connection((host, int(port))) as connection:
        connection.sendall(head + f"{len(part):x}\r\n".encode() + part + b"\r\n")
        connection.settimeout(0)
        answer = b""
        while sent < total_bytes:
            try:
                answer += connection.recv(65536)
                if answer:
                    break
            except BlockingIOError:
                pass
            try:
                connection.settimeout(5)
                connection.sendall(f"{len(chunk):x}\r\n".encode() + chunk + b"\r\n")
                connection.settimeout(0)
                sent += len(chunk)
            except OSError:
                break  # the service closed the connection after its answer
        connection.settimeout(10)
        with contextlib.suppress(OSError):
            while not _complete(answer):  # the head and then its body, however the bytes arrive
                data = connection.recv(65536)
                if not data:
                    break
                answer += data
    return answer, sent


def _complete(answer: bytes) -> bool:
    head, found, body = answer.partition(b"\r\n\r\n")
    if not found:
        return False
    length = re.search(rb"(?im)^content-length:\s*(\d+)", head)
    return length is None or len(body) >= int(length.group(1))


def test_a_1_gb_chunked_upload_stops_at_the_limit_with_413(edge_agent):
    answer, sent = _chunked_upload(edge_agent.url, 1 << 30)
    assert answer.startswith(b"HTTP/1.1 413"), answer[:200]
    assert b"exceeds the limit of 20000000 bytes" in answer
    assert sent < 4 * EDGE_LIMIT, sent  # it stopped near the limit, not after the gigabyte
    assert sum(path.stat().st_size for path in edge_agent.spool.rglob("*") if path.is_file()) == 0


def test_a_png_past_the_pixel_budget_is_refused_before_it_is_decoded(edge_agent):
    buffer = io.BytesIO()
    Image.new("1", (12_000, 12_000)).save(buffer, format="PNG")  # 144 Mpx: 430 MB once decoded
    idle_mb, _ = peak_rss_mb(edge_agent.process.pid)
    response = httpx.post(
        edge_agent.url + "/v1/solve",
        data={"question": "What is in the room?"},
        files=[("images", ("huge.png", buffer.getvalue(), "image/png"))],
        timeout=120,
    )
    assert response.status_code == 413, response.text
    assert "12000x12000 pixels; the limit is 40000000" in response.json()["detail"]
    _, peak_mb = peak_rss_mb(edge_agent.process.pid)
    assert peak_mb - idle_mb < 200, (idle_mb, peak_mb)


def test_too_many_files_are_refused_while_parsing(edge_agent):
    files = [("images", (f"{n}.png", b"\x89PNG", "image/png")) for n in range(40)]
    response = httpx.post(edge_agent.url + "/v1/solve", data={"question": "q?"}, files=files, timeout=60)
    assert response.status_code == 422 and "at most 32" in response.json()["detail"], response.text


# ---- keys never reach a log, in any encoding ------------------------------------------------------

KEY = "edge-key-Zq8wPm3Lr7"


def test_a_key_in_any_encoding_never_reaches_the_log(tmp_path):
    port = free_port()
    env = {**os.environ, "PYSPATIAL_API_KEYS": KEY, "PYSPATIAL_DATA_DIR": str(tmp_path / "data")}
    env["REDIS_URL"] = ""
    log_path = tmp_path / "recon.log"
    with open(log_path, "wb") as log:  # the info-level log of `pyspatial serve`, access lines included
        process = subprocess.Popen(
            container_command("recon", port), cwd=tmp_path, env=env, stdout=log, stderr=log
        )
    url = f"http://127.0.0.1:{port}"
    basic = base64.b64encode(f"someone:{KEY}".encode()).decode()
    try:
        wait_healthy(url, process)
        with httpx.Client(base_url=url, timeout=60) as client:
            assert client.get(NO_SCENE, params={"api_key": KEY}).status_code == 401
            assert client.get(NO_SCENE, params={"key": KEY}).status_code == 401
            assert client.get(NO_SCENE, headers={"Authorization": f"Basic {basic}"}).status_code == 401
            encoded = base64.urlsafe_b64encode(KEY.encode()).decode()
            assert client.get(f"/v1/scenes/{encoded}", headers={"Authorization": f"Bearer {KEY}"}).status_code
    finally:
        process.send_signal(signal.SIGTERM)
        process.wait(timeout=30)
    text = log_path.read_text(errors="replace")
    assert "GET /v1/scenes/" in text  # the access log is on: the lines are there, redacted
    assert "[redacted]" in text
    for form in (KEY, basic, base64.b64encode(KEY.encode()).decode().rstrip("="), KEY[:12]):
        assert form not in text, form


# ---- malformed bodies are the documented 422 ------------------------------------------------------


@pytest.mark.parametrize("path", ["/v1/camera-motion", "/v1/render", f"/v1/scenes/{'0' * 24}/reconstruct"])
@pytest.mark.parametrize("body", [b'{"scene_id": "\xff\xfe"}', b"[" * 5000 + b"]" * 5000, b"{"])
def test_a_malformed_json_body_is_a_422_with_the_standard_body(recon, path, body):
    response = httpx.post(
        recon.url + path, content=body, headers={"Content-Type": "application/json"}, timeout=30
    )
    assert response.status_code == 422, response.text
    assert list(response.json()) == ["detail"] and isinstance(response.json()["detail"], str)
    assert response.json()["detail"].startswith("invalid request")
