"""Running CPU work away from the event loop.

`run_cpu` is for short work (decoding, serialization, rendering, camera motion): anyio's worker
threads with a bounded number at once. `run_in_daemon_thread` is for reconstructions, which may run
for minutes: a daemon thread does not keep a draining process alive (SIGTERM exits within the drain
time; the lease is released and another replica takes the scene over).
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable
from typing import TypeVar

import anyio

T = TypeVar("T")


async def run_cpu(function: Callable[..., T], *args, limiter: anyio.CapacityLimiter | None = None) -> T:
    return await anyio.to_thread.run_sync(function, *args, limiter=limiter)


async def run_in_daemon_thread(function: Callable[..., T], *args, name: str = "reconstruction") -> T:
    loop = asyncio.get_running_loop()
    future: asyncio.Future = loop.create_future()

    def settle(result, error) -> None:
        if future.done():  # the awaiting task was cancelled: nobody wants the result
            return
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(result)

    def target() -> None:
        try:
            result = function(*args)
        except BaseException as error:  # handed to the awaiting task, raised there
            result, failure = None, error
        else:
            failure = None
        try:
            loop.call_soon_threadsafe(settle, result, failure)
        except RuntimeError:  # the loop has closed (process shutting down): nobody to tell
            pass

    threading.Thread(target=target, name=name, daemon=True).start()
    return await future
