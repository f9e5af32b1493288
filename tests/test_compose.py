"""docker-compose.yml, the Dockerfiles and the README agree with the code they deploy."""

from __future__ import annotations

import importlib
import json
import re
import subprocess
import sys
from pathlib import Path
from urllib.parse import urlparse

import pytest
import yaml

from shared.wire.settings import DEFAULT_AGENT_PORT, DEFAULT_RECON_PORT, AgentSettings, ReconSettings
from tests.support.processes import REPO_ROOT

COMPOSE = yaml.safe_load((REPO_ROOT / "docker-compose.yml").read_text())
SERVICES = COMPOSE["services"]
APP_SERVICES = {"recon": DEFAULT_RECON_PORT, "recon-gpu": DEFAULT_RECON_PORT, "agent": DEFAULT_AGENT_PORT}
SETTING_ENV_NAMES = {
    f"PYSPATIAL_{name.upper()}" for name in (*ReconSettings.model_fields, *AgentSettings.model_fields)
}
SETTING_ENV_NAMES |= {"REDIS_URL"}


def default_of(value: str) -> str:
    """The value compose uses when the variable is unset: `${VAR:-default}` gives default."""
    match = re.fullmatch(r"\$\{\w+:-(.*)\}", value)
    return match.group(1) if match else value


def dockerfile_command(path: Path) -> list[str]:
    lines = [line for line in path.read_text().splitlines() if line.startswith("CMD ")]
    assert len(lines) == 1, f"{path} needs exactly one CMD"
    return json.loads(lines[0].removeprefix("CMD "))


def test_every_service_is_there_with_a_healthcheck():
    assert {"redis", "recon", "recon-gpu", "agent", "nginx"} <= set(SERVICES)
    for name, service in SERVICES.items():
        if service.get("profiles") == ["tools"]:  # one-off commands (`docker compose run`)
            continue
        assert service.get("healthcheck", {}).get("test"), f"{name} has no healthcheck"
    assert SERVICES["redis"]["image"].startswith("redis:7")
    assert "redis-cli" in SERVICES["redis"]["healthcheck"]["test"]


def test_ports_and_urls_agree_with_the_settings_defaults():
    for name, port in APP_SERVICES.items():
        assert f":{port}/healthz" in " ".join(SERVICES[name]["healthcheck"]["test"])
    published = sorted(str(entry) for entry in SERVICES["nginx"]["ports"])
    assert published == sorted(f"{port}:{port}" for port in (DEFAULT_AGENT_PORT, DEFAULT_RECON_PORT))
    recon_url = urlparse(default_of(SERVICES["agent"]["environment"]["PYSPATIAL_RECON_URL"]))
    assert (recon_url.hostname, recon_url.port) == ("nginx", DEFAULT_RECON_PORT)  # balanced
    redis_url = urlparse(SERVICES["recon"]["environment"]["REDIS_URL"])
    assert redis_url.hostname == "redis" and redis_url.port == 6379
    assert urlparse(AgentSettings.model_fields["recon_url"].default).port == DEFAULT_RECON_PORT


def test_start_order_waits_for_health():
    assert SERVICES["recon"]["depends_on"]["redis"]["condition"] == "service_healthy"
    assert SERVICES["agent"]["depends_on"]["recon"]["condition"] == "service_healthy"
    for name in ("agent", "recon"):
        assert SERVICES["nginx"]["depends_on"][name]["condition"] == "service_healthy"
    for name in (*APP_SERVICES, "nginx"):
        assert SERVICES[name]["restart"] == "unless-stopped"


def test_recon_storage_and_models():
    recon = SERVICES["recon"]
    assert recon["environment"]["PYSPATIAL_DATA_DIR"] == "/data"
    data_volume = next(v.split(":")[0] for v in recon["volumes"] if v.endswith(":/data"))
    assert data_volume in COMPOSE["volumes"]
    # the store of record: a named volume every replica mounts read-write; Redis a bounded LRU cache
    assert recon["environment"]["PYSPATIAL_STORE_DIR"] == "/store"
    assert "recon-store:/store" in recon["volumes"] and "recon-store" in COMPOSE["volumes"]
    assert "recon-store:/store" in SERVICES["recon-gpu"]["volumes"]
    redis_command = SERVICES["redis"]["command"]
    assert redis_command[redis_command.index("--maxmemory-policy") + 1] == "allkeys-lru"
    # Checkpoints: the hub cache volume (the image's HF_HOME), read-only for the service and
    # writable for the one-off `weights` tool that pulls into it.
    dockerfile = (REPO_ROOT / "services" / "recon" / "Dockerfile").read_text()
    assert "HF_HOME=/hf" in dockerfile
    assert "hub-cache:/hf:ro" in [v.split("#")[0].strip() for v in recon["volumes"]]
    weights = SERVICES["weights"]
    assert weights["profiles"] == ["tools"] and weights["entrypoint"] == ["pyspatial", "weights"]
    assert "hub-cache:/hf" in weights["volumes"] and "hub-cache" in COMPOSE["volumes"]
    assert not any("CHECKPOINT" in name for name in recon["environment"])  # found in the cache


def test_gpu_service_reserves_an_nvidia_device_under_a_profile():
    gpu = SERVICES["recon-gpu"]
    assert gpu["profiles"] == ["gpu"]
    devices = gpu["deploy"]["resources"]["reservations"]["devices"]
    assert devices[0]["driver"] == "nvidia" and "gpu" in devices[0]["capabilities"]
    assert "resources" not in SERVICES["recon"].get("deploy", {})  # the default stack needs no GPU


def test_environment_names_are_settings_fields():
    for name, service in SERVICES.items():
        for variable in service.get("environment", {}):
            assert variable in SETTING_ENV_NAMES, f"{name}: {variable} is no field of the settings"
    for variable, value in SERVICES["agent"]["environment"].items():
        if "MODEL" in variable:
            assert value == f"${{{variable}:-}}", f"{variable} must pass through with an empty default"


@pytest.mark.parametrize("name", ["recon", "agent"])
def test_each_dockerfile_starts_through_pyspatial_serve(name):
    """The containers start as `pyspatial serve` does, so the serve settings (drain, proxies) apply."""
    build = SERVICES[name]["build"]
    dockerfile = REPO_ROOT / build["context"] / build["dockerfile"]
    assert dockerfile.is_file()
    text = dockerfile.read_text()
    assert text.startswith("#") and "FROM python:3.11-slim" in text
    assert "libgomp1" in text and "libusb-1.0-0" in text
    command = dockerfile_command(dockerfile)
    assert command[:3] == ["pyspatial", "serve", name], command
    assert "uvicorn" not in text.split("CMD ")[-1]  # plain uvicorn would ignore PYSPATIAL_DRAIN_S
    assert command[command.index("--host") + 1] == "0.0.0.0"
    assert command[command.index(f"--{name}-port") + 1] == str(APP_SERVICES[name])
    assert 'pyspatial = "cli.main:app"' in (REPO_ROOT / "pyproject.toml").read_text()  # the console script
    assert "--forwarded-allow-ips" not in command  # X-Forwarded-For: PYSPATIAL_TRUSTED_PROXIES only


def test_readme_documents_every_setting():
    sys.path.insert(0, str(REPO_ROOT / "scripts"))
    try:
        settings_table = importlib.import_module("settings_table")
    finally:
        sys.path.remove(str(REPO_ROOT / "scripts"))
    readme = (REPO_ROOT / "README.md").read_text()
    for variable in SETTING_ENV_NAMES:
        assert f"`{variable}`" in readme, f"README.md does not mention {variable}"
    for row in settings_table.table().splitlines():
        assert row in readme, f"README's Configuration is stale (run scripts/settings_table.py): {row}"


def test_gpu_service_builds_the_cuda_torch():
    compose = yaml.safe_load((REPO_ROOT / "docker-compose.yml").read_text())
    gpu = compose["services"]["recon-gpu"]
    assert gpu["build"]["args"]["TORCH_VARIANT"] == "cuda"
    assert gpu["deploy"]["resources"]["reservations"]["devices"][0]["driver"] == "nvidia"
    assert "TORCH_VARIANT" not in str(compose["services"]["recon"].get("build", {}).get("args", {}))
    dockerfile = (REPO_ROOT / "services" / "recon" / "Dockerfile").read_text()
    assert "ARG TORCH_VARIANT=cpu" in dockerfile and '"$TORCH_VARIANT" = "cuda"' in dockerfile


# ---- scale-out behind nginx, non-root containers ------------------------------------------

NGINX_CONF = REPO_ROOT / "deploy" / "nginx" / "nginx.conf"
SERVICE_UID = "10001"


def nginx_servers(text: str) -> dict[int, str]:
    """listen port -> the upstream URL its location proxies to (through a `set` variable)."""
    servers = {}
    for block in re.findall(r"server\s*\{(.*?)\n    \}", text, flags=re.S):
        port = int(re.search(r"listen\s+(\d+);", block).group(1))
        variable = re.search(r"proxy_pass\s+\$(\w+);", block).group(1)
        servers[port] = re.search(rf"set\s+\${variable}\s+(\S+);", block).group(1)
    return servers


def test_replicas_scale_behind_nginx():
    for name in ("recon", "agent"):
        service = SERVICES[name]
        assert "ports" not in service and "container_name" not in service, f"{name} cannot be scaled"
        assert service["deploy"]["replicas"] >= 2
    mount = next(v for v in SERVICES["nginx"]["volumes"] if v.endswith(":/etc/nginx/nginx.conf:ro"))
    assert (REPO_ROOT / mount.split(":")[0]).resolve() == NGINX_CONF.resolve()
    servers = nginx_servers(NGINX_CONF.read_text())
    assert servers == {
        DEFAULT_AGENT_PORT: f"http://agent:{DEFAULT_AGENT_PORT}",
        DEFAULT_RECON_PORT: f"http://recon:{DEFAULT_RECON_PORT}",
    }
    text = NGINX_CONF.read_text()
    assert "resolver 127.0.0.11" in text  # Docker's DNS, asked at request time: new replicas join
    limit_mb = int(re.search(r"client_max_body_size (\d+)m;", text).group(1))
    assert limit_mb * 2**20 >= ReconSettings.model_fields["max_request_bytes"].default
    read_timeout = int(re.search(r"proxy_read_timeout (\d+)s;", text).group(1))
    assert read_timeout > AgentSettings.model_fields["recon_timeout_s"].default


def test_nginx_accepts_the_config(tmp_path):
    (tmp_path / "logs").mkdir()
    result = subprocess.run(
        ["nginx", "-t", "-p", str(tmp_path), "-e", "stderr", "-c", str(NGINX_CONF)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert result.returncode == 0, result.stderr
    assert "test is successful" in result.stderr


def test_recon_is_reachable_only_with_the_agents_key():
    recon_keys = SERVICES["recon"]["environment"]["PYSPATIAL_API_KEYS"]
    agent_key = SERVICES["agent"]["environment"]["PYSPATIAL_RECON_API_KEY"]
    # recon takes it as a service key (it acts for the tenant the agent names), the agent sends it
    assert recon_keys == "*:" + agent_key and agent_key.startswith("${PYSPATIAL_RECON_API_KEY:?")  # required


@pytest.mark.parametrize("name", ["recon", "agent"])
def test_containers_run_as_a_non_root_user(name):
    build = SERVICES[name]["build"]
    text = (REPO_ROOT / build["context"] / build["dockerfile"]).read_text()
    after_last_from = text[text.rindex("\nFROM ") :]
    users = re.findall(r"^USER (\S+)$", after_last_from, flags=re.M)
    assert users and users[-1].split(":")[0] == SERVICE_UID
    assert f"--uid {SERVICE_UID}" in text
    assert text.index("\nUSER ") > text.index("pip install --no-cache-dir .")  # installs ran as root
    if name == "recon":
        assert f"chown {SERVICE_UID}:{SERVICE_UID} /data /hf /store" in text  # volumes it writes
