"""`POST /v1/solve` with `Accept: text/event-stream`: the solve's stages as Server-Sent Events.

One request, one stream, no state kept on the server: it works behind any load balancer and there
is nothing to expire. Events (the `event:` name is the payload's `type`):
- `stage`: a stage started, finished or failed (`StageEvent`);
- `result`: the `SolveResponse` (last event of a successful solve);
- `error`: the status code and message plain `/v1/solve` would have answered (last event).
Requests that are refused before the solve starts (bad JSON, too large) get a plain 4xx instead.
A comment line goes out every `KEEPALIVE_S` so proxies keep the connection open during long stages.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import AsyncIterator, Callable

import anyio
from pydantic import BaseModel
from starlette.responses import StreamingResponse

from services.agent.cancellation import CLIENT_GONE, Cancellation
from services.agent.errors import SolveError
from services.agent.infrastructure import InfrastructureFailure, recon_error_status
from services.agent.llm import LLMError
from services.agent.progress import ProgressCallback
from shared.imaging.codecs import ImageError
from shared.wire.bodies import BodyTooLarge
from shared.wire.client import ServiceError, ServiceUnreachable
from shared.wire.schemas import ErrorEvent, ResultEvent, SolveResponse, StageEvent

log = logging.getLogger("pyspatial.agent")

KEEPALIVE_S = 10.0
EVENT_STREAM = "text/event-stream"


def wants_event_stream(accept: str) -> bool:
    return EVENT_STREAM in accept.lower()


def failure_status(error: BaseException) -> tuple[int, str]:
    """The status and message a failed solve is reported with (as the JSON route's handlers do)."""
    if isinstance(error, SolveError):
        return error.status_code, error.message
    if isinstance(error, BodyTooLarge):
        return 413, str(error)
    if isinstance(error, ImageError):
        return (413 if error.over_limit else 400), str(error)
    if isinstance(error, (ServiceError, ServiceUnreachable)):
        return recon_error_status(error)
    if isinstance(error, InfrastructureFailure):
        return error.status_code, error.message
    if isinstance(error, LLMError):
        return 502, f"language model: {error}"
    return 500, f"internal error: {type(error).__name__}: {error}"


def sse(event: BaseModel) -> bytes:
    return f"event: {event.type}\ndata: {event.model_dump_json()}\n\n".encode()


def event_stream(
    run: Callable[[ProgressCallback], SolveResponse], cancellation: Cancellation
) -> StreamingResponse:
    """Run `run(progress)` in a worker thread and stream its progress, then its result or error.

    When the client goes away (Starlette stops the stream), `cancellation` fires: the solve stops.
    """
    return StreamingResponse(
        _events(run, cancellation),
        media_type=EVENT_STREAM,
        headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"},  # nginx: do not buffer
    )


async def _events(
    run: Callable[[ProgressCallback], SolveResponse], cancellation: Cancellation
) -> AsyncIterator[bytes]:
    loop = asyncio.get_running_loop()
    queue: asyncio.Queue[StageEvent] = asyncio.Queue()
    started = time.perf_counter()
    current: list[str] = []  # the stage running now, for an error event

    def progress(stage: str, state: str, detail: str = "") -> None:
        elapsed = round((time.perf_counter() - started) * 1e3, 1)
        event = StageEvent(stage=stage, state=state, detail=detail[:2000], elapsed_ms=elapsed)
        loop.call_soon_threadsafe(queue.put_nowait, event)

    solve = asyncio.ensure_future(anyio.to_thread.run_sync(run, progress))
    try:
        async for chunk in _until_done(solve, queue, current):
            yield chunk
    finally:
        if not solve.done():  # the client went away: stop the solve's work
            cancellation.cancel()
            log.warning("solve cancelled: %s", CLIENT_GONE)
            solve.add_done_callback(lambda future: future.cancelled() or future.exception())
    error = solve.exception()
    if error is None:
        yield sse(ResultEvent(result=solve.result()))
        return
    status, detail = failure_status(error)
    if status >= 500:
        log.error("solve failed: %s", detail, exc_info=error if status == 500 else None)
    attempts = error.attempts if isinstance(error, InfrastructureFailure) else None
    stage = current[0] if current else None
    yield sse(ErrorEvent(status_code=status, detail=detail, stage=stage, attempts=attempts))


async def _until_done(
    solve: asyncio.Future, queue: asyncio.Queue[StageEvent], current: list[str]
) -> AsyncIterator[bytes]:
    """Stage events as they come, keep-alive comments in quiet stretches, until the solve ends."""
    while True:
        getter = asyncio.ensure_future(queue.get())
        done, _ = await asyncio.wait({getter, solve}, timeout=KEEPALIVE_S, return_when="FIRST_COMPLETED")
        if getter in done:
            event = getter.result()
            current[:] = [event.stage] if event.state == "started" else []
            yield sse(event)
            continue
        getter.cancel()
        if solve in done:
            break
        yield b": still working\n\n"
    while not queue.empty():  # events sent just before the thread returned
        yield sse(queue.get_nowait())
