"""Failures of what the agent depends on (the recon service), told apart from failed programs.

A program whose `reconstruct()` failed because the recon service died is not a wrong program: the
solve must end as a 502/503/504 that says so, with the attempts made so far, never as a 200
with `answer: null`.
"""

from __future__ import annotations

import math

from shared.wire.client import ServiceError, ServiceTimeout, ServiceUnreachable
from shared.wire.schemas import AttemptRecord


class InfrastructureFailure(Exception):
    """The solve stopped because a service it depends on failed (HTTP 502/503/504)."""

    def __init__(self, status_code: int, message: str, attempts: list[AttemptRecord]) -> None:
        super().__init__(message)
        self.status_code = status_code
        self.message = message
        self.attempts = attempts


def is_infrastructure_error(error: Exception) -> bool:
    return isinstance(error, ServiceUnreachable) or (
        isinstance(error, ServiceError) and error.status_code >= 500
    )


def gateway_status(error: Exception) -> int:
    """504 for a timeout, 503 when unreachable or the dependency said 503, else 502."""
    if isinstance(error, ServiceTimeout):
        return 504
    if isinstance(error, ServiceUnreachable):
        return 503
    if isinstance(error, ServiceError) and error.status_code == 503:
        return 503
    return 502


def recon_error_status(error: ServiceError | ServiceUnreachable) -> tuple[int, str]:
    """The status and message the agent answers when a recon call failed.

    Recon's 4xx about the client's input pass through. Recon refusing the agent's own key (401,
    403, or throttling its failed authentications) is a 502 that says so: a misconfigured stack,
    not the client's fault, and waiting does not cure it. Recon rate-limiting the agent (429) is a
    503: the stack is overloaded for now (recon_retry_after gives the wait it asked for).
    """
    if isinstance(error, ServiceUnreachable):
        return gateway_status(error), str(error)
    if error.refused_key:
        return 502, (
            f"reconstruction service refused the agent's own API key (PYSPATIAL_RECON_API_KEY; "
            f"answered {error.status_code}): {error.message}"
        )
    if error.status_code == 429:
        status = 503
    else:
        status = error.status_code if error.status_code < 500 else gateway_status(error)
    return status, f"reconstruction service: {error.message}"


def recon_retry_after(error: ServiceError | ServiceUnreachable) -> dict[str, str]:
    """The Retry-After header of the agent's 503 for `error`: recon's own when it named one."""
    if isinstance(error, ServiceError) and error.retry_after is not None:
        if recon_error_status(error)[0] == 503:
            return {"Retry-After": str(max(1, math.ceil(error.retry_after)))}
    return {}  # the catch-all adds the default wait to a 503 that names none


class FailureRecordingClient:
    """Wraps the recon client of one solve and remembers the first infrastructure failure.

    The sandbox turns a tool's exception into the program's error; this record is how the
    pipeline learns afterwards that the cause was the service, not the program.
    """

    def __init__(self, client) -> None:
        self._client = client
        self.failure: Exception | None = None

    def __getattr__(self, name: str):
        attribute = getattr(self._client, name)
        if not callable(attribute):
            return attribute

        def recorded(*args, **kwargs):
            try:
                return attribute(*args, **kwargs)
            except Exception as error:
                if self.failure is None and is_infrastructure_error(error):
                    self.failure = error
                raise

        return recorded
