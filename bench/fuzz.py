"""schemathesis against the live services, API keys on and off: 5xx and undocumented statuses.

    .venv/bin/python -m bench.fuzz [--examples 5] [--services recon agent] [--keys off on]

Each service runs as a real uvicorn process (recon on the posed-rgbd backbone with a throwaway
data dir; the agent in front of it, offline planner and answerer), and schemathesis' CLI fuzzes
every operation of its /openapi.json with the checks `not_a_server_error` (no 5xx that is not
documented) and `status_code_conformance` (every status is one the route documents). With keys
on, the fuzzer sends a valid key. The exit status is schemathesis' worst (0: nothing found).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from shared.local.services import running_service

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
KEY = "fuzz-key-0123456789"
CHECKS = "not_a_server_error,status_code_conformance"


def _schemathesis() -> list[str]:
    binary = shutil.which("schemathesis") or str(Path(sys.executable).with_name("schemathesis"))
    if not Path(binary).exists():
        raise SystemExit("schemathesis is not installed: pip install -e '.[dev]'")
    return [binary]


def fuzz(url: str, examples: int, key: str | None) -> tuple[int, str]:
    command = [*_schemathesis(), "run", f"{url}/openapi.json", "--checks", CHECKS]
    command += ["--max-examples", str(examples), "--workers", "1", "--request-timeout", "120"]
    command += ["--continue-on-failure"]
    if key:
        command += ["--header", f"Authorization: Bearer {key}"]
    finished = subprocess.run(command, capture_output=True, text=True)
    return finished.returncode, finished.stdout[-4000:] + finished.stderr[-2000:]


def stack_env(data_dir: str, keys: bool) -> tuple[dict[str, str], dict[str, str]]:
    recon = {"PYSPATIAL_DATA_DIR": data_dir, "PYSPATIAL_BACKBONE": "posed-rgbd", "REDIS_URL": ""}
    agent: dict[str, str] = {}
    if keys:
        recon["PYSPATIAL_API_KEYS"] = KEY
        agent = {"PYSPATIAL_API_KEYS": KEY, "PYSPATIAL_RECON_API_KEY": KEY}
    return recon, agent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="bench.fuzz", description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=5, help="schemathesis examples per operation")
    parser.add_argument("--services", nargs="+", default=["recon", "agent"], choices=["recon", "agent"])
    parser.add_argument("--keys", nargs="+", default=["off", "on"], choices=["off", "on"])
    args = parser.parse_args(argv)
    worst = 0
    for keys in args.keys:
        with tempfile.TemporaryDirectory(prefix="pyspatial-fuzz-") as data_dir:
            recon_env, agent_env = stack_env(data_dir, keys == "on")
            with running_service(RECON_APP, recon_env) as recon:
                agent_env["PYSPATIAL_RECON_URL"] = recon.url
                with running_service(AGENT_APP, agent_env) as agent:
                    urls = {"recon": recon.url, "agent": agent.url}
                    for name in args.services:
                        started = time.monotonic()
                        code, output = fuzz(urls[name], args.examples, KEY if keys == "on" else None)
                        worst = max(worst, code)
                        print(f"== {name}, keys {keys}: exit {code} in {time.monotonic() - started:.0f} s")
                        print(output)
    return worst


if __name__ == "__main__":
    raise SystemExit(main())
