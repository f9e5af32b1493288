"""The one error a solve raises for the client to see: a status code and a message."""

from __future__ import annotations


class SolveError(Exception):
    """A request cannot be solved for a reason the client should see (status + message)."""

    def __init__(self, status_code: int, message: str) -> None:
        super().__init__(message)
        self.status_code = status_code
        self.message = message


__all__ = ["SolveError"]
