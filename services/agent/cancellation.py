"""Stop a solve's work when its client goes away: the sandbox process, the model call, the next stage.

A solve runs in a worker thread, which Python cannot interrupt from outside. So the route that
starts it makes a `Cancellation` and cancels it when the client disconnects (the page's Cancel
button aborts its request; a closed tab does the same); each kind of work listens in its own way:
- the step log checks it at every step's start and end (`SolveLog.record`), so no further stage
  starts and the step that was running ends as aborted;
- the sandbox kills the program's process group the moment it fires (`run_worker`'s `cancel`);
- a model call is abandoned: the agent's model clients open one connection per call
  (`abortable_http_client`) and the cancellation shuts that socket down, so the blocked read ends
  at once and the model server sees the client leave; retries and backoff sleeps stop too.

A reconstruction already asked of recon finishes there (recon caches it, so solving again is quick);
the solve stops when it returns. `SolveCancelled` derives from BaseException, as asyncio's
CancelledError does, so the `except Exception` of a stage that turns failures into answers cannot
swallow it.
"""

from __future__ import annotations

import asyncio
import contextlib
import contextvars
import logging
import socket
import threading
from collections.abc import Awaitable, Callable, Iterator
from typing import TypeVar

import httpx
from starlette.types import Receive

T = TypeVar("T")

log = logging.getLogger("pyspatial.agent")

CLIENT_GONE = "the client went away"


class SolveCancelled(BaseException):  # noqa: N818 (it is not an error: the client left)
    """The solve was cancelled (its client went away); its work has been stopped."""


class Cancellation:
    """A one-shot signal, set from any thread; callbacks run once, when it is set."""

    def __init__(self) -> None:
        self._event = threading.Event()
        self._lock = threading.Lock()
        self._callbacks: dict[int, Callable[[], None]] = {}
        self._next_id = 0
        self.reason = ""

    @property
    def cancelled(self) -> bool:
        return self._event.is_set()

    def cancel(self, reason: str = CLIENT_GONE) -> None:
        with self._lock:
            if self._event.is_set():
                return
            self.reason = reason
            self._event.set()
            callbacks, self._callbacks = list(self._callbacks.values()), {}
        for callback in callbacks:
            try:
                callback()
            except Exception:  # one listener failing must not keep the others from stopping
                log.exception("a cancellation callback failed")

    def check(self) -> None:
        """Raise SolveCancelled when cancelled."""
        if self._event.is_set():
            raise SolveCancelled(f"cancelled: {self.reason}")

    def wait(self, seconds: float) -> bool:
        """Sleep up to `seconds`; True (at once) when cancelled meanwhile."""
        return self._event.wait(max(0.0, seconds))

    def add(self, callback: Callable[[], None]) -> int | None:
        """Run `callback` when the cancellation fires (at once, returning None, if it has)."""
        with self._lock:
            if not self._event.is_set():
                self._next_id += 1
                self._callbacks[self._next_id] = callback
                return self._next_id
        callback()
        return None

    def remove(self, key: int | None) -> None:
        with self._lock:
            self._callbacks.pop(key, None)

    @contextlib.contextmanager
    def on_cancel(self, callback: Callable[[], None]) -> Iterator[None]:
        """Run `callback` if the cancellation fires while the block runs (at once if it already has)."""
        key = self.add(callback)
        try:
            yield
        finally:
            self.remove(key)


# The cancellation of the solve this thread works for: model clients read it (the calls to them sit
# deep in codegen and answering, which need not know about it).
_CURRENT: contextvars.ContextVar[Cancellation | None] = contextvars.ContextVar(
    "solve_cancellation", default=None
)


def current() -> Cancellation | None:
    return _CURRENT.get()


@contextlib.contextmanager
def bound(cancellation: Cancellation | None) -> Iterator[None]:
    """Make `cancellation` the current one for the block (in this thread's context)."""
    token = _CURRENT.set(cancellation)
    try:
        yield
    finally:
        _CURRENT.reset(token)


def abortable_http_client(timeout: float) -> httpx.Client:
    """An httpx client whose connections the current cancellation can shut down mid-request.

    No keep-alive, so every request opens its own connection and httpcore's `trace` extension
    hands us its socket when it connects; `shutdown` (not `close`) wakes a thread blocked in recv.
    """

    def watch_connection(request: httpx.Request) -> None:
        cancellation = current()
        if cancellation is None:
            return
        cancellation.check()

        def trace(event: str, info: dict) -> None:
            if event == "connection.connect_tcp.complete":  # kept until the solve ends: a few per solve
                sock = info["return_value"].get_extra_info("socket")
                cancellation.add(lambda: _shut(sock))

        request.extensions["trace"] = trace

    return httpx.Client(
        timeout=timeout,
        limits=httpx.Limits(max_keepalive_connections=0),
        event_hooks={"request": [watch_connection]},
    )


async def cancel_when_client_leaves(receive: Receive, work: Awaitable[T], cancellation: Cancellation) -> T:
    """Await `work`; if the client disconnects first, fire `cancellation` and raise SolveCancelled.

    The request body has been read by then, so the next ASGI message is the disconnect.
    """
    work_task = asyncio.ensure_future(work)
    watcher = asyncio.ensure_future(_disconnected(receive))
    try:
        await asyncio.wait({work_task, watcher}, return_when=asyncio.FIRST_COMPLETED)
    finally:
        watcher.cancel()
    if not work_task.done():
        cancellation.cancel()
        log.warning("solve cancelled: %s", CLIENT_GONE)
        work_task.add_done_callback(lambda task: task.cancelled() or task.exception())
        raise SolveCancelled(CLIENT_GONE)
    return work_task.result()


async def _disconnected(receive: Receive) -> None:
    while (await receive())["type"] != "http.disconnect":
        pass


def _shut(sock: socket.socket) -> None:
    with contextlib.suppress(OSError):  # already closed: the call ended on its own
        sock.shutdown(socket.SHUT_RDWR)


__all__ = [
    "CLIENT_GONE",
    "Cancellation",
    "SolveCancelled",
    "abortable_http_client",
    "bound",
    "cancel_when_client_leaves",
    "current",
]
