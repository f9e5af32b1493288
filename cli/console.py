"""One rich console for the command line, and the one-line error handling every command shares."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import typer
from rich.console import Console

from cli.api_keys import AGENT_KEY_ENV, RECON_KEY_ENV
from shared.wire.client import AgentClient, ServiceError, ServiceUnreachable

console = Console(highlight=False)
errors = Console(stderr=True, highlight=False)

# Exit codes: 1 = a service answered with an error (or the demo got a wrong answer),
# 2 = bad usage or nothing answered at the service URL.
EXIT_SERVICE_ERROR = 1
EXIT_UNREACHABLE = 2
EXIT_USAGE = 2


def fail(message: str, code: int = EXIT_USAGE) -> typer.Exit:
    """Print `message` as one red line on stderr and return the Exit to raise."""
    errors.print(f"[bold red]error:[/] {message}", soft_wrap=True)
    return typer.Exit(code)


@contextlib.contextmanager
def service_errors(recon_key_flag: str = "--recon-api-key") -> Iterator[None]:
    """Turn the clients' exceptions into one clear line and an exit code, never a traceback.

    `recon_key_flag` is how this command takes the recon service's key (for the 401 hint).
    """
    try:
        yield
    except ServiceUnreachable as error:
        raise fail(str(error), EXIT_UNREACHABLE) from None
    except ServiceError as error:
        raise fail(explain_service_error(error, recon_key_flag), EXIT_SERVICE_ERROR) from None


def explain_service_error(error: ServiceError, recon_key_flag: str = "--recon-api-key") -> str:
    """One line a person can act on: which key to set on 401, when to retry on 429."""
    if error.status_code == 401:
        hint = f"{recon_key_flag} or {RECON_KEY_ENV}"
        if error.service == AgentClient.service_name:
            hint = f"--api-key or {AGENT_KEY_ENV}"
        reason = error.message.split(":", 1)[0]  # "missing bearer API key" or "invalid API key"
        return f"the {error.service} refused the API key ({reason}): set {hint}"
    if error.status_code == 429:
        when = f"retry in {error.retry_after:g} s" if error.retry_after else "retry later"
        return f"the {error.service} is rate limiting this key: {when} ({error.message})"
    # str(error) reads "POST /v1/solve answered 422: <the service's message>".
    return str(error)
