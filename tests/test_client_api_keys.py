"""The clients' side of API keys: the CLI and the Python API against keyed services, over real HTTP.

Recon accepts `recon-key` (people) and `agent-to-recon` (the agent's key); the agent accepts
`user-key` and `limited-key`, with a small burst so one key can be driven into its rate limit.
"""

from __future__ import annotations

import uuid

import httpx
import pytest

from shared.local.services import running_service
from shared.wire.api import Scene, SpatialToolkit
from shared.wire.client import ServiceError
from shared.wire.schemas import SolveResponse
from tests.test_cli import EXAMPLE, SPEC, pyspatial, scene_id_of

IMAGES = [str(EXAMPLE / name) for name in SPEC["images"]]


@pytest.fixture(scope="module")
def keyed(tmp_path_factory, redis_url):
    recon_env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("keyed-recon")),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"client-keys-{uuid.uuid4().hex[:8]}",
        "PYSPATIAL_BACKBONE": "classical",
        "PYSPATIAL_API_KEYS": "recon-key,agent-to-recon",
    }
    with running_service("services.recon.app:create_app", recon_env) as recon:
        agent_env = {
            "PYSPATIAL_RECON_URL": recon.url,
            "PYSPATIAL_RECON_API_KEY": "agent-to-recon",
            "PYSPATIAL_API_KEYS": "user-key,limited-key",
            "PYSPATIAL_RATE_LIMIT_PER_MINUTE": "1",
            "PYSPATIAL_RATE_LIMIT_BURST": "8",
            "PYSPATIAL_CODE_MODEL": "",
            "PYSPATIAL_ANSWER_MODEL": "",
        }
        with running_service("services.agent.app:create_app", agent_env) as agent:
            yield {"recon": recon, "agent": agent}


def test_solve_without_or_with_a_wrong_key_is_one_line_that_names_the_setting(keyed, tmp_path):
    url = keyed["agent"].url
    missing = pyspatial("solve", *IMAGES, "-q", SPEC["question"], "--agent-url", url, cwd=tmp_path)
    assert missing.returncode == 1
    assert (
        "the agent service refused the API key (missing bearer API key): set --api-key or PYSPATIAL_API_KEY"
        in missing.stderr
    ), missing.stderr
    wrong = pyspatial(
        "solve", *IMAGES, "-q", SPEC["question"], "--agent-url", url, cwd=tmp_path,
        extra_env={"PYSPATIAL_API_KEY": "guessed"},
    )  # fmt: skip
    assert wrong.returncode == 1 and "(invalid API key)" in wrong.stderr, wrong.stderr
    assert "Traceback" not in missing.stderr + wrong.stderr


def test_solve_with_the_key_from_the_environment_answers(keyed, tmp_path):
    result = pyspatial(
        "solve", *IMAGES, "-q", SPEC["question"], "--json", "--agent-url", keyed["agent"].url,
        cwd=tmp_path, extra_env={"PYSPATIAL_API_KEY": "user-key"},
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert SolveResponse.model_validate_json(result.stdout).answer == SPEC["expected_answer"]


def test_reconstruct_and_render_send_the_recon_key(keyed, tmp_path):
    url = keyed["recon"].url
    refused = pyspatial("reconstruct", *IMAGES, "--recon-url", url, cwd=tmp_path)
    assert refused.returncode == 1
    assert (
        "the reconstruction service refused the API key (missing bearer API key): "
        "set --api-key or PYSPATIAL_RECON_API_KEY" in refused.stderr
    ), refused.stderr
    built = pyspatial("reconstruct", *IMAGES, "--recon-url", url, "--api-key", "recon-key", cwd=tmp_path)
    assert built.returncode == 0, built.stderr
    scene_id = scene_id_of(built.stdout)
    out = tmp_path / "turned.png"
    rendered = pyspatial(
        "render", scene_id, "--view", "1", "--rotate-left", "20", "--out", str(out), "--recon-url", url,
        cwd=tmp_path, extra_env={"PYSPATIAL_RECON_API_KEY": "recon-key"},
    )  # fmt: skip
    assert rendered.returncode == 0, rendered.stderr
    assert out.read_bytes().startswith(b"\x89PNG")


def test_a_rate_limited_key_is_told_when_to_retry(keyed, tmp_path):
    url = keyed["agent"].url
    with httpx.Client(base_url=url, headers={"Authorization": "Bearer limited-key"}, timeout=60) as client:
        statuses = [client.get("/v1/example").status_code for _ in range(9)]
    assert statuses[-1] == 429, statuses  # the burst of 8 is spent
    result = pyspatial(
        "solve", *IMAGES, "-q", SPEC["question"], "--agent-url", url, "--api-key", "limited-key", cwd=tmp_path
    )
    assert result.returncode == 1
    assert "the agent service is rate limiting this key: retry in " in result.stderr, result.stderr


def test_eval_stops_at_once_on_a_refused_key(keyed, tmp_path):
    questions = tmp_path / "questions.jsonl"
    questions.write_text("")  # the key is checked before the questions are read
    result = pyspatial(
        "eval", "omni3d", "--jsonl", str(questions), "--image-root", str(tmp_path),
        "--agent-url", keyed["agent"].url, "--no-progress", cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 2
    assert "refused the API key" in result.stdout + result.stderr, result.stdout + result.stderr


def test_python_api_sends_the_recon_key(keyed, monkeypatch):
    url = keyed["recon"].url
    scene = Scene(EXAMPLE)  # reconstructed by the CLI test already: a cache hit
    monkeypatch.delenv("PYSPATIAL_RECON_API_KEY", raising=False)
    refused = SpatialToolkit(url)
    with pytest.raises(ServiceError) as error:
        refused.reconstruct(scene)
    assert error.value.status_code == 401 and error.value.service == "reconstruction service"
    refused.close()
    given = SpatialToolkit(url, api_key="recon-key")
    assert given.reconstruct(scene).num_views == len(IMAGES)
    given.close()
    monkeypatch.setenv("PYSPATIAL_RECON_API_KEY", "recon-key")
    from_env = SpatialToolkit(url)  # reads PYSPATIAL_RECON_API_KEY when it first needs the service
    assert from_env.reconstruct(scene).num_views == len(IMAGES)
    from_env.close()


def test_demo_with_keys_in_its_environment_keys_both_services_and_still_answers(tmp_path):
    # Both services demand the key; the agent must get it for recon and the demo must send it.
    result = pyspatial(
        "demo", "--out", str(tmp_path / "demo"), cwd=tmp_path, timeout=180.0,
        extra_env={"PYSPATIAL_API_KEYS": "demo-key"},
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    assert "both services demand a key" in result.stdout
    assert f"expected {SPEC['expected_answer']}, got {SPEC['expected_answer']}: correct" in result.stdout
