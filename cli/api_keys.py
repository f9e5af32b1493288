"""The API-key options of the commands that call a service, and the environment variables behind them.

The agent's key is PYSPATIAL_API_KEY (one of the agent's PYSPATIAL_API_KEYS); the recon key is
PYSPATIAL_RECON_API_KEY, the same variable the agent service reads for its own calls to recon.
"""

from __future__ import annotations

import typer

from shared.wire.access import SERVICE_TENANT, parse_tenant_keys
from shared.wire.settings import AccessSettings, AgentSettings

AGENT_KEY_ENV = "PYSPATIAL_API_KEY"
RECON_KEY_ENV = "PYSPATIAL_RECON_API_KEY"


def _key_option(flag: str, envvar: str, service: str, annotated: bool):
    help_text = f"Bearer API key of the {service} service (needed when it has PYSPATIAL_API_KEYS)."
    # With Annotated[...] the default sits after `=`, so the first argument is the flag itself.
    declarations = (flag,) if annotated else (None, flag)
    return typer.Option(*declarations, envvar=envvar, show_envvar=True, help=help_text)


def agent_key_option(flag: str = "--api-key", annotated: bool = False):
    return _key_option(flag, AGENT_KEY_ENV, "agent", annotated)


def recon_key_option(flag: str = "--api-key", annotated: bool = False):
    return _key_option(flag, RECON_KEY_ENV, "reconstruction", annotated)


def started_services_key() -> str | None:
    """The service key, else the first of PYSPATIAL_API_KEYS, which services started here will demand.

    `serve all` and `demo` start both services with this environment, so with keys set the agent
    (and the demo's own client) must send one of them.
    """
    keys = parse_tenant_keys(AccessSettings())
    # with tenants, the agent needs the service key (`*:key`): it acts for each caller's tenant
    chosen = [key for key, tenant in keys.items() if tenant == SERVICE_TENANT] or list(keys)
    return chosen[0].decode() if chosen else None


def sibling_recon_env() -> dict[str, str]:
    """Environment that lets an agent started here call its sibling recon service with a key."""
    if AgentSettings().recon_api_key is not None:
        return {}  # the operator chose the agent's recon key; it passes through unchanged
    key = started_services_key()
    return {RECON_KEY_ENV: key} if key else {}
