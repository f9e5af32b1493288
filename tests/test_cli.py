"""The `pyspatial` command against real services (uvicorn processes) on the bundled example."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image

from cli.images import collect_images
from cli.render import parse_pose
from shared.wire.schemas import SolveResponse
from tests.support.processes import REPO_ROOT, ServiceProcess, free_port, start_service

EXAMPLE = REPO_ROOT / "examples" / "living_room"
SPEC = json.loads((EXAMPLE / "example.json").read_text())


def pyspatial(
    *args: str, cwd: Path, timeout: float = 120.0, extra_env: dict[str, str] | None = None
) -> subprocess.CompletedProcess:
    """Run the real command line in a child process; a wide terminal keeps rich from wrapping."""
    env = {**os.environ, "COLUMNS": "200", "PYTHONUNBUFFERED": "1"}
    for name in ("PYSPATIAL_RECON_URL", "PYSPATIAL_API_KEY", "PYSPATIAL_API_KEYS", "PYSPATIAL_RECON_API_KEY"):
        env.pop(name, None)
    env.update(extra_env or {})
    return subprocess.run(
        [sys.executable, "-P", "-m", "cli.main", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


@pytest.fixture(scope="module")
def services(redis_url: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, ServiceProcess]]:
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("cli-data")),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"test-cli-{uuid.uuid4().hex}",
        "PYSPATIAL_BACKBONE": "classical",
    }
    recon = start_service("services.recon.app:create_app", env)
    try:
        agent = start_service("services.agent.app:create_app", {**env, "PYSPATIAL_RECON_URL": recon.url})
    except BaseException:
        recon.stop()
        raise
    try:
        yield {"recon": recon, "agent": agent}
    finally:
        agent.stop()
        recon.stop()


def scene_id_of(output: str) -> str:
    match = re.search(r"scene (\w+)", output)
    assert match, output
    return match.group(1)


def test_reconstruct_prints_the_cameras_and_saves_a_ply(services, tmp_path):
    ply = tmp_path / "cloud.ply"
    result = pyspatial(
        "reconstruct", str(EXAMPLE), "--ply", str(ply), "--recon-url", services["recon"].url, cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    assert "3 of 3 views registered" in result.stdout
    assert "backbone classical" in result.stdout
    points = int(re.search(r"registered, (\d+) points", result.stdout).group(1))
    assert points > 1000
    assert ply.read_bytes().startswith(b"ply")
    assert f"element vertex {points}".encode() in ply.read_bytes()[:500]


def test_render_turns_an_input_view_and_takes_a_pose(services, tmp_path):
    recon_url = services["recon"].url
    summary = pyspatial("reconstruct", str(EXAMPLE), "--recon-url", recon_url, cwd=tmp_path)
    scene_id = scene_id_of(summary.stdout)

    turned = tmp_path / "turned.png"
    result = pyspatial(
        "render", scene_id, "--view", "1", "--rotate-right", "20", "--width", "160", "--height", "120",
        "--out", str(turned), "--recon-url", recon_url, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    image = np.asarray(Image.open(turned))
    assert image.shape == (120, 160, 3)
    assert image.std() > 5  # a rendered room, not a blank canvas

    # The reconstruction's own pose of view 2, given as 12 numbers, renders too.
    extrinsic = re.search(r"extrinsic \(3x4\): (.*)", result.stdout).group(1)
    numbers = " ".join(f"{v:.6f}" for v in np.asarray(json.loads(extrinsic)).ravel())
    posed = tmp_path / "posed.png"
    result = pyspatial(
        "render", scene_id, "--pose", numbers, "--out", str(posed), "--recon-url", recon_url, cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    assert Image.open(posed).size == (512, 512)


def test_render_rejects_a_bad_pose_in_one_line(services, tmp_path):
    result = pyspatial("render", "abc", "--pose", "1 2 3", "--recon-url", services["recon"].url, cwd=tmp_path)
    assert result.returncode == 2
    assert "12 (3x4) or 16 (4x4) numbers, got 3" in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_solve_json_answers_the_bundled_example(services, tmp_path):
    result = pyspatial(
        "solve", *(str(EXAMPLE / name) for name in SPEC["images"]), "--question", SPEC["question"],
        "--json", "--agent-url", services["agent"].url, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    response = SolveResponse.model_validate_json(result.stdout)
    assert response.answer == SPEC["expected_answer"]
    assert "describe_camera_motion" in response.program
    assert "From view 1 to view 2, in view 1's image axes, the camera moved right" in response.clue.text
    # The stages as they happened, on stderr (plain lines: stderr is no terminal here).
    stages = re.findall(r"^(\w+) done at [\d.]+ s", result.stderr, flags=re.MULTILINE)
    assert stages == ["upload", "reconstruction", "program", "execution", "answer"], result.stderr


def test_solve_saves_rendered_clue_images(services, tmp_path):
    question = "What is behind me in view 1? A. a wall B. a sofa C. a window D. a door"
    result = pyspatial(
        "solve", str(EXAMPLE), "-q", question, "--out", str(tmp_path / "clues"),
        "--agent-url", services["agent"].url, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "turn_around" in result.stdout  # the program, printed
    saved = re.findall(r"clue image: (\S+)", result.stdout)
    assert saved, result.stdout
    for path in saved:
        assert Image.open(path).format == "PNG"  # --out was absolute, so are the printed paths
    assert "timings (ms)" in result.stdout


def test_solve_without_an_agent_url_starts_and_stops_the_local_stack(tmp_path):
    result = pyspatial("solve", str(EXAMPLE), "-q", SPEC["question"], "--json", cwd=tmp_path, timeout=300.0)
    assert result.returncode == 0, result.stderr
    assert SolveResponse.model_validate_json(result.stdout).answer == SPEC["expected_answer"]
    assert "no --agent-url: starting the local stack" in result.stderr
    assert "local stack stopped" in result.stderr
    url = re.search(r"local stack up at (http://\S+),", result.stderr).group(1)
    with pytest.raises(httpx.TransportError):  # stopped after the answer
        httpx.get(url + "/healthz", timeout=2.0)


def test_unreachable_service_is_one_clear_line(tmp_path):
    url = f"http://127.0.0.1:{free_port()}"
    result = pyspatial("solve", str(EXAMPLE), "-q", "Where?", "--agent-url", url, cwd=tmp_path)
    assert result.returncode == 2
    assert "cannot reach the agent service" in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_service_error_shows_status_and_message(services, tmp_path):
    not_an_image = tmp_path / "notes.png"
    not_an_image.write_text("this is text, not a PNG")
    result = pyspatial("reconstruct", str(not_an_image), "--recon-url", services["recon"].url, cwd=tmp_path)
    assert result.returncode == 1
    assert re.search(r"answered 4\d\d: ", result.stderr), result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_bench_help_lists_the_benches(tmp_path):
    result = pyspatial("bench", "--help", cwd=tmp_path)
    assert result.returncode == 0
    for name in ("render", "classical_accuracy", "vggt"):
        assert f"{name}:" in result.stdout
    unknown = pyspatial("bench", "no_such_bench", cwd=tmp_path)
    assert unknown.returncode == 2 and "available: " in unknown.stderr


def test_demo_runs_the_whole_stack_and_answers_correctly(tmp_path):
    result = pyspatial("demo", "--out", str(tmp_path / "demo"), cwd=tmp_path, timeout=180.0)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "cache memory" in result.stdout  # no Redis: the in-process cache
    assert "backbone classical" in result.stdout
    assert f"expected {SPEC['expected_answer']}, got {SPEC['expected_answer']}: correct" in result.stdout
    novel = re.search(r"rendered from the points\): (\S+)", result.stdout).group(1)
    assert Image.open(novel).size == tuple(SPEC["image_size"])
    assert (tmp_path / "demo" / "logs" / "recon.log").is_file()
    assert "web page:" in result.stdout and "reconstruction done at" in result.stderr


def test_images_come_from_files_or_one_sorted_folder(tmp_path):
    for name in ("b.png", "a.jpg", "notes.txt"):
        (tmp_path / name).write_bytes(b"x")
    assert [p.name for p in collect_images([tmp_path])] == ["a.jpg", "b.png"]
    assert collect_images([tmp_path / "b.png", tmp_path / "a.jpg"])[0].name == "b.png"
    with pytest.raises(ValueError, match="no such file"):
        collect_images([tmp_path / "missing.png"])


def test_poses_parse_from_numbers_and_json_files(tmp_path):
    pose = np.asarray(SPEC["cameras"][0])
    assert np.allclose(parse_pose(" ".join(map(str, pose.ravel()))), pose)
    as_4x4 = np.vstack([pose, [0, 0, 0, 1]])
    (tmp_path / "pose.json").write_text(json.dumps(as_4x4.tolist()))
    assert parse_pose(str(tmp_path / "pose.json")).shape == (4, 4)
    with pytest.raises(ValueError, match="not orthonormal"):
        parse_pose("1 0 0 0 0 1 0 0 0 0 2 0")


def test_serve_all_runs_both_and_stops_both_on_sigterm(tmp_path):
    recon_port, agent_port = free_port(), free_port()
    env = {**os.environ, "PYSPATIAL_DATA_DIR": str(tmp_path / "data"), "REDIS_URL": ""}
    command = [sys.executable, "-P", "-m", "cli.main", "serve", "all"]
    command += ["--recon-port", str(recon_port), "--agent-port", str(agent_port)]
    parent = subprocess.Popen(
        command, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT
    )
    try:
        ready = None  # two services' imports: a loaded machine takes minutes
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline:
            with contextlib.suppress(httpx.HTTPError):
                ready = httpx.get(f"http://127.0.0.1:{agent_port}/readyz", timeout=1.0)
                if ready.status_code == 200:
                    break
            assert parent.poll() is None, parent.stdout.read().decode()
            time.sleep(0.2)
        assert ready is not None and ready.status_code == 200, "serve all did not become ready in 180 s"
        assert ready.json()["recon"]["cache"] == "memory"  # no REDIS_URL: the in-process cache
        parent.send_signal(signal.SIGTERM)
        assert parent.wait(timeout=30) == 0
    finally:
        if parent.poll() is None:  # SIGTERM first: it stops both services, a bare kill orphans them
            parent.terminate()
            try:
                parent.wait(timeout=30)
            except subprocess.TimeoutExpired:
                parent.kill()
                parent.wait()
    log = parent.stdout.read().decode()
    assert "recon service: backbone=classical" in log and "agent service: recon=" in log
    for port in (recon_port, agent_port):
        with pytest.raises(httpx.ConnectError):
            httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1.0)


def test_synth_writes_a_question_set(tmp_path):
    result = pyspatial("synth", "--out", str(tmp_path / "set"), "--scenes", "1", "--seed", "4",
                       "--width", "64", "--height", "48", cwd=tmp_path)  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = (tmp_path / "set" / "questions.jsonl").read_text().splitlines()
    assert lines and f"{len(lines)} questions over 1 scenes" in result.stdout
    first = json.loads(lines[0])
    assert (tmp_path / "set" / first["images"][0]).is_file()
