"""The records of one solve, in order, and the callbacks that watch each step start and end.

A stage never reports progress itself: it fills its record (shared.wire.schemas: `SceneStep`,
`ReconstructionStep`, `ProgramStep`, `ExecutionStep`, `AnswerStep`) inside `SolveLog.record`, which
times the step, keeps it, and tells the callbacks registered for its type. The event stream of a
solve is one such callback (services/agent/progress.py); the response reads the records at the end
(services/agent/response.py). Callbacks run in the solve's thread, in registration order.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Literal, TypeVar

from services.agent.cancellation import Cancellation, SolveCancelled
from shared.wire.schemas import StepRecord

# "aborted": the step raised; the solve stops there and the error it raised says what failed.
Moment = Literal["started", "finished", "aborted"]
StepCallback = Callable[[StepRecord, Moment], None]
Step = TypeVar("Step", bound=StepRecord)


class StepCallbacks:
    """Callbacks by record type: one registered for `StepRecord` sees every step."""

    def __init__(self) -> None:
        self._by_type: dict[type[StepRecord], list[StepCallback]] = {}

    def register(self, step_type: type[StepRecord], callback: StepCallback) -> None:
        self._by_type.setdefault(step_type, []).append(callback)

    def notify(self, step: StepRecord, moment: Moment) -> None:
        for step_type in type(step).__mro__:
            for callback in self._by_type.get(step_type, ()):
                callback(step, moment)


class SolveLog:
    """The steps of one solve as they happen, timed from the solve's start.

    With a `cancellation`, no step starts once it has fired, and the step running when it fires
    ends as aborted (SolveCancelled), whatever the work inside made of its stopped process.
    """

    def __init__(
        self, callbacks: StepCallbacks | None = None, cancellation: Cancellation | None = None
    ) -> None:
        self.started = time.perf_counter()
        self.steps: list[StepRecord] = []
        self.callbacks = callbacks or StepCallbacks()
        self.cancellation = cancellation or Cancellation()

    def elapsed_ms(self) -> float:
        return round((time.perf_counter() - self.started) * 1e3, 2)

    @contextmanager
    def record(self, step: Step) -> Iterator[Step]:
        """Keep `step`, time the block that fills it, and tell the callbacks when it starts and ends."""
        self.cancellation.check()
        step.started_ms = self.elapsed_ms()
        self.steps.append(step)
        self.callbacks.notify(step, "started")
        try:
            yield step
            self.cancellation.check()
        except BaseException as error:
            step.duration_ms = round(self.elapsed_ms() - step.started_ms, 2)
            cancelled = isinstance(error, SolveCancelled)  # not what the step's own work said
            step.error = str(error) if cancelled else step.error or f"{type(error).__name__}: {error}"
            self.callbacks.notify(step, "aborted")
            raise
        step.duration_ms = round(self.elapsed_ms() - step.started_ms, 2)
        self.callbacks.notify(step, "finished")

    def of(self, step_type: type[Step]) -> list[Step]:
        return [step for step in self.steps if isinstance(step, step_type)]

    def total_ms(self, step_type: type[StepRecord]) -> float:
        return round(sum(step.duration_ms for step in self.of(step_type)), 2)


__all__ = ["Moment", "SolveLog", "StepCallback", "StepCallbacks"]
