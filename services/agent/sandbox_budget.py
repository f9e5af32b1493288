"""How much sandbox one agent and one solve may use: a cap on concurrent sandboxes with a bounded
queue (beyond it /v1/solve is a 503 with Retry-After), and a CPU budget per solve across its
attempts. Both are settings (shared/wire/settings.py: PYSPATIAL_SANDBOX_*); each hit has a name the
repair loop and the client see: `busy` (the 503) and `cpu_budget` (the attempt's error kind).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

from services.agent.sandbox import SandboxLimits


class SandboxBusy(Exception):
    """Every sandbox is running and the queue is full: the client should retry later (503)."""

    def __init__(self, running: int, waiting: int, retry_after_s: int) -> None:
        super().__init__(
            f"busy: all {running} program sandboxes are running and {waiting} solves are waiting "
            f"for one; retry in {retry_after_s} s"
        )
        self.retry_after_s = retry_after_s


class SandboxGate:
    """At most `max_running` sandboxes at once; at most `max_waiting` admitted solves beyond those.

    A solve is admitted when its request arrives (so the refusal can still be a 503, before any
    event is streamed) and holds its ticket until it ends; each program run then takes one of the
    `max_running` slots, waiting in line when all are taken.
    """

    def __init__(self, max_running: int, max_waiting: int, retry_after_s: int) -> None:
        self.max_running = max_running
        self.max_waiting = max_waiting
        self.retry_after_s = retry_after_s
        self._slots = threading.BoundedSemaphore(max_running)
        self._lock = threading.Lock()
        self._admitted = 0

    def admit(self) -> SolveTicket:
        """A ticket for one solve; SandboxBusy when running and waiting solves fill the queue."""
        with self._lock:
            if self._admitted >= self.max_running + self.max_waiting:
                raise SandboxBusy(self.max_running, self.max_waiting, self.retry_after_s)
            self._admitted += 1
        return SolveTicket(self)

    def _release_ticket(self) -> None:
        with self._lock:
            self._admitted -= 1

    @property
    def admitted(self) -> int:
        return self._admitted

    @contextmanager
    def slot(self) -> Iterator[None]:
        """One running sandbox (waits for a free slot; the admission bound keeps the line short)."""
        with self._slots:
            yield


@dataclass
class SolveTicket:
    gate: SandboxGate
    released: bool = False

    def release(self) -> None:
        if not self.released:
            self.released = True
            self.gate._release_ticket()


@dataclass
class CpuBudget:
    """CPU seconds one solve's programs may use in total, across the code model's repairs."""

    total_s: float
    used_s: float = 0.0
    runs: list[float] = field(default_factory=list)

    @property
    def left_s(self) -> float:
        return max(self.total_s - self.used_s, 0.0)

    def spent_error(self) -> str | None:
        """The named error of a run refused because the budget is spent, else None."""
        if self.left_s >= 1.0:  # RLIMIT_CPU counts whole seconds
            return None
        return (
            f"cpu_budget: this solve's programs used {self.used_s:.1f} s of CPU, its budget is "
            f"{self.total_s:g} s across all attempts; no further program runs"
        )

    def limits_for_next_run(self, limits: SandboxLimits) -> SandboxLimits:
        """The run's limits with its CPU limit cut to what is left of the budget."""
        return replace(limits, cpu_seconds=max(1, min(limits.cpu_seconds, math.floor(self.left_s))))

    def charge(self, cpu_seconds: float) -> None:
        self.runs.append(cpu_seconds)
        self.used_s += cpu_seconds


__all__ = ["CpuBudget", "SandboxBusy", "SandboxGate", "SolveTicket"]
