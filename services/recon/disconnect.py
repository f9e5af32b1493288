"""Cancel a request's work when its client goes away.

Starlette does not cancel a handler when the connection drops. `until_disconnected` runs the
work next to a task that waits for the ASGI `http.disconnect` message (the request body has been
read by then, so the next message is the disconnect) and cancels the work when it comes. The
reconstruction jobs (jobs.py) then drop a queued job nobody waits for.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable
from typing import TypeVar

from starlette.requests import Request

from services.recon.errors import ReconServiceError

T = TypeVar("T")


class ClientGone(ReconServiceError):
    status_code = 499  # nginx's "client closed request": nobody reads it, the logs do


async def until_disconnected(request: Request, work: Awaitable[T]) -> T:
    work_task = asyncio.ensure_future(work)
    watcher = asyncio.create_task(_wait_for_disconnect(request))
    try:
        await asyncio.wait({work_task, watcher}, return_when=asyncio.FIRST_COMPLETED)
    except asyncio.CancelledError:
        work_task.cancel()
        raise
    finally:
        watcher.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await watcher
    if not work_task.done():
        work_task.cancel()
        with contextlib.suppress(asyncio.CancelledError, Exception):
            await work_task
        raise ClientGone("the client closed the connection; its work was cancelled")
    return work_task.result()


async def _wait_for_disconnect(request: Request) -> None:
    while True:
        message = await request.receive()
        if message["type"] == "http.disconnect":
            return
