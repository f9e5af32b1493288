"""`pyspatial weights` against a local stand-in of the model hub (real HTTP, real huggingface_hub).

The stand-in serves the tiny Pi3X fixture as `yyfz233/Pi3X` `model.safetensors`; the commands run
as subprocesses with HF_HOME in a temporary folder and HF_ENDPOINT at the stand-in.
"""

from __future__ import annotations

import hashlib
import os
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file, save_file

from tests.support import pi3_fixtures
from tests.support.hub_standin import HubStandIn

ROOT = Path(__file__).resolve().parent.parent
PI3_DATA = pi3_fixtures.DATA
VGGT_DATA = ROOT / "tests" / "data" / "vggt"


@pytest.fixture
def hub() -> Iterator[HubStandIn]:
    standin = HubStandIn()
    standin.host("yyfz233/Pi3X", "model.safetensors", PI3_DATA / "tiny_pi3x.safetensors")
    standin.url = standin.start()  # type: ignore[attr-defined]
    yield standin
    standin.stop()


def run_weights(tmp_path: Path, endpoint: str, *args: str, **env: str) -> subprocess.CompletedProcess[str]:
    environment = {
        key: value for key, value in os.environ.items() if not key.startswith(("HF_", "PYSPATIAL_"))
    }
    environment.update(
        HF_HOME=str(tmp_path / "hf"),
        HF_ENDPOINT=endpoint,
        HF_HUB_DISABLE_TELEMETRY="1",
        PYSPATIAL_PI3X_CONFIG=str(PI3_DATA / "tiny_pi3x_config.json"),
        PYSPATIAL_PI3_CONFIG=str(PI3_DATA / "tiny_pi3_config.json"),
        PYSPATIAL_VGGT_CONFIG=str(VGGT_DATA / "tiny_vggt_config.json"),
        COLUMNS="200",
        **env,
    )
    return subprocess.run(
        [sys.executable, "-m", "cli.main", "weights", *args],
        cwd=ROOT,
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
    )


def cached_file(tmp_path: Path, repo: str = "yyfz233/Pi3X") -> Path:
    commit = HubStandIn.commit(repo)
    folder = "models--" + repo.replace("/", "--")
    return tmp_path / "hf" / "hub" / folder / "snapshots" / commit / "model.safetensors"


def test_pull_downloads_into_the_hub_cache_and_list_and_verify_see_it(
    tmp_path: Path, hub: HubStandIn
) -> None:
    pulled = run_weights(tmp_path, hub.url, "pull", "pi3x")  # type: ignore[attr-defined]
    assert pulled.returncode == 0, pulled.stderr
    path = cached_file(tmp_path)
    assert path.read_bytes() == (PI3_DATA / "tiny_pi3x.safetensors").read_bytes()
    assert path.is_symlink() and path.resolve().parent.name == "blobs"
    assert "tensors match the architecture" in pulled.stdout
    assert [method for method, _, _ in hub.requests] == ["HEAD", "GET"]

    listed = run_weights(tmp_path, hub.url, "list")  # type: ignore[attr-defined]
    assert listed.returncode == 0, listed.stderr
    row = next(line for line in listed.stdout.splitlines() if "pi3x" in line)
    megabytes = f"{(PI3_DATA / 'tiny_pi3x.safetensors').stat().st_size / 1e6:.1f} MB"
    assert "yyfz233/Pi3X" in row and " yes " in row and megabytes in row and "models--yyfz233--Pi3X" in row
    assert "run `pyspatial weights pull pi3`" in next(
        line for line in listed.stdout.splitlines() if " pi3 " in line
    )

    verified = run_weights(tmp_path, hub.url, "verify", "pi3x")  # type: ignore[attr-defined]
    assert verified.returncode == 0 and "fits the architecture" in verified.stdout

    again = run_weights(tmp_path, hub.url, "pull", "pi3x")  # type: ignore[attr-defined]
    assert again.returncode == 0
    assert [method for method, _, _ in hub.requests].count("GET") == 1  # cached: only a HEAD


def test_a_dropped_download_resumes_where_it_stopped(tmp_path: Path, hub: HubStandIn) -> None:
    # huggingface_hub writes in 10 MiB chunks and resumes from the last whole chunk, so the file
    # must be larger than one chunk: the tiny weights with 12 MB of header metadata.
    big = tmp_path / "big.safetensors"
    save_file(
        load_file(str(PI3_DATA / "tiny_pi3x.safetensors")), str(big), metadata={"padding": "x" * 12_000_000}
    )
    hosted = hub.host("yyfz233/Pi3X", "model.safetensors", big)
    hub.drop_after = 11_000_000
    pulled = run_weights(tmp_path, hub.url, "pull", "pi3x")  # type: ignore[attr-defined]
    assert pulled.returncode == 0, pulled.stderr
    assert "Trying to resume download" in pulled.stderr
    gets = [ranged for method, _, ranged in hub.requests if method == "GET"]
    assert gets == [None, f"bytes={10 * 2**20}-"]  # the second asks only for what is missing
    assert hashlib.sha256(cached_file(tmp_path).read_bytes()).hexdigest() == hosted.sha256


def test_a_file_whose_tensors_do_not_fit_is_refused_with_the_list(tmp_path: Path, hub: HubStandIn) -> None:
    hub.host("yyfz233/Pi3X", "model.safetensors", PI3_DATA / "tiny_pi3.safetensors")
    pulled = run_weights(tmp_path, hub.url, "pull", "pi3x")  # type: ignore[attr-defined]
    assert pulled.returncode == 1
    message = " ".join(pulled.stderr.split())
    assert "does not fit the pi3x architecture, so it was removed from the cache" in message
    missing, unexpected = pi3_fixtures.pi3_weights_read_as_pi3x()
    assert f"{len(missing)} missing tensors: {missing[0]}" in message
    assert f"{len(unexpected)} unexpected tensors: {unexpected[0]}" in message
    assert not cached_file(tmp_path).exists()
    listed = run_weights(tmp_path, hub.url, "list")  # type: ignore[attr-defined]
    assert "run `pyspatial weights pull pi3x`" in listed.stdout


def _closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_a_pull_with_no_network_says_so_and_names_hf_endpoint(tmp_path: Path) -> None:
    # huggingface_hub retries a refused connection five times (about 23 s) before it gives up.
    pulled = run_weights(tmp_path, f"http://127.0.0.1:{_closed_port()}", "pull", "pi3x")
    assert pulled.returncode == 1
    message = " ".join(pulled.stderr.split())
    assert "cannot reach the model hub at http://127.0.0.1:" in message and "HF_ENDPOINT" in message
    assert "Traceback" not in pulled.stderr


def test_hf_hub_offline_uses_the_cache_only(tmp_path: Path, hub: HubStandIn) -> None:
    offline = run_weights(tmp_path, hub.url, "pull", "pi3x", HF_HUB_OFFLINE="1")  # type: ignore[attr-defined]
    assert offline.returncode == 1 and "HF_HUB_OFFLINE is set" in offline.stderr
    assert hub.requests == []
    assert run_weights(tmp_path, hub.url, "pull", "pi3x").returncode == 0  # type: ignore[attr-defined]
    requests = len(hub.requests)
    cached = run_weights(tmp_path, hub.url, "pull", "pi3x", HF_HUB_OFFLINE="1")  # type: ignore[attr-defined]
    assert cached.returncode == 0 and len(hub.requests) == requests


def test_unknown_repository_revision_and_name(tmp_path: Path, hub: HubStandIn) -> None:
    revision = run_weights(tmp_path, hub.url, "pull", "pi3x", "--revision", "v9")  # type: ignore[attr-defined]
    assert revision.returncode == 1 and "has no yyfz233/Pi3X/model.safetensors@v9" in " ".join(
        revision.stderr.split()
    )
    missing = run_weights(tmp_path, hub.url, "pull", "pi3")  # type: ignore[attr-defined]
    assert missing.returncode == 1 and "has no yyfz233/Pi3/model.safetensors@main" in " ".join(
        missing.stderr.split()
    )
    unknown = run_weights(tmp_path, hub.url, "pull", "dust3r")  # type: ignore[attr-defined]
    assert unknown.returncode == 2 and "choose one of vggt, pi3, pi3x" in unknown.stderr


def test_verify_reads_a_pt_file_and_an_explicit_path(tmp_path: Path) -> None:
    state = load_file(str(VGGT_DATA / "tiny_vggt.safetensors"))
    torch.save(state, tmp_path / "model.pt")
    verified = run_weights(
        tmp_path, "http://127.0.0.1:9", "verify", "vggt", "--path", str(tmp_path / "model.pt")
    )
    assert verified.returncode == 0, verified.stderr
    assert "verifying it loads it" in verified.stdout and "fits the architecture" in verified.stdout
    wrong = run_weights(
        tmp_path, "http://127.0.0.1:9", "verify", "pi3", "--path", str(PI3_DATA / "tiny_pi3x.safetensors")
    )
    assert wrong.returncode == 1 and "unexpected tensors" in wrong.stderr
    absent = run_weights(tmp_path, "http://127.0.0.1:9", "verify", "pi3")
    assert absent.returncode == 1 and "run `pyspatial weights pull pi3`" in absent.stderr
