"""One rich console for the command line, and the one-line error handling every command shares."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import typer
from rich.console import Console

from shared.client import ServiceError, ServiceUnreachable

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
def service_errors() -> Iterator[None]:
    """Turn the clients' exceptions into one clear line and an exit code, never a traceback."""
    try:
        yield
    except ServiceUnreachable as error:
        raise fail(str(error), EXIT_UNREACHABLE) from None
    except ServiceError as error:
        # str(error) reads "POST /v1/solve answered 422: <the service's message>".
        raise fail(str(error), EXIT_SERVICE_ERROR) from None
