"""schemathesis over both live services, API keys on and off: no 5xx and no undocumented status.

The lean form of `bench.fuzz` (issue 21's "done when"): real uvicorn processes, schemathesis' own
CLI with the checks `not_a_server_error` and `status_code_conformance`, one example per operation
so it stays in the default run. The bench runs the same with more examples (BENCHMARKS.md).
"""

from __future__ import annotations

import pytest

from bench.fuzz import AGENT_APP, KEY, RECON_APP, fuzz, stack_env
from shared.local.services import running_service


@pytest.mark.parametrize("keys", ["off", "on"])
def test_schemathesis_finds_no_5xx_and_no_undocumented_status(tmp_path, keys):
    recon_env, agent_env = stack_env(str(tmp_path), keys == "on")
    key = KEY if keys == "on" else None
    with running_service(RECON_APP, recon_env) as recon:
        agent_env["PYSPATIAL_RECON_URL"] = recon.url
        with running_service(AGENT_APP, agent_env) as agent:
            for name, url in (("recon", recon.url), ("agent", agent.url)):
                code, output = fuzz(url, examples=1, key=key)
                assert code == 0, f"{name}, keys {keys}: schemathesis exit {code}\n{output}"
