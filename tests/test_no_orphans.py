"""`serve recon` leaves no process behind: its decode workers and multiprocessing's resource
tracker exit with it under SIGTERM and SIGINT, and die with it under SIGKILL (issue 19).

Checked by process id: the children of the real command, recorded while it runs, must all be
gone a few seconds after it ends.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import httpx
import numpy as np
import psutil

from shared.imaging.codecs import encode_image
from tests.support.processes import REPO_ROOT, free_port


def _serve_recon(tmp_path, port: int) -> subprocess.Popen:
    env = {
        **os.environ,
        "PYSPATIAL_DATA_DIR": str(tmp_path),
        "PYSPATIAL_DECODE_PROCESSES": "2",
        "PYSPATIAL_DRAIN_S": "2",
        "PYTHONUNBUFFERED": "1",
    }
    env.pop("REDIS_URL", None)
    command = [sys.executable, "-m", "cli.main", "serve", "recon", "--recon-port", str(port)]
    log = open(tmp_path / "serve.log", "wb")  # noqa: SIM115 - the process writes it until it ends
    return subprocess.Popen(command, cwd=REPO_ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)


def _wait_ready(url: str, process: subprocess.Popen, tmp_path) -> None:
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise AssertionError((tmp_path / "serve.log").read_text(errors="replace"))
        try:
            if httpx.get(url + "/healthz", timeout=1.0).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.2)
    raise AssertionError("serve recon did not become ready")


def test_serve_recon_leaves_no_child_behind(tmp_path):
    # One service per signal, started side by side: the start-up (imports) is the slow part.
    signals = {"SIGTERM": signal.SIGTERM, "SIGINT": signal.SIGINT, "SIGKILL": signal.SIGKILL}
    started = {}
    try:
        for name in signals:
            folder = tmp_path / name
            folder.mkdir()
            port = free_port()
            started[name] = (folder, f"http://127.0.0.1:{port}", _serve_recon(folder, port))
        children = {}
        for name, (folder, url, process) in started.items():
            _wait_ready(url, process, folder)
            # An upload starts the decode workers (and with them the resource tracker).
            pictures = np.random.default_rng(0).integers(0, 255, size=(2, 48, 64, 3), dtype=np.uint8)
            files = [("images", (f"{i}.png", encode_image(picture))) for i, picture in enumerate(pictures)]
            response = httpx.post(url + "/v1/scenes", files=files, timeout=60)
            assert response.status_code in (200, 201), response.text
            children[name] = psutil.Process(process.pid).children(recursive=True)
            assert len(children[name]) >= 2, children[name]  # two decode workers at least
        for name, (_, _, process) in started.items():
            process.send_signal(signals[name])
        for name, (_, _, process) in started.items():
            process.wait(timeout=30)
            _, alive = psutil.wait_procs(children[name], timeout=10)
            assert not alive, (name, [(p.pid, " ".join(p.cmdline())) for p in alive])
    finally:
        for _, _, process in started.values():
            if process.poll() is None:
                process.kill()
                process.wait(timeout=10)
