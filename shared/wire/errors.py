"""Error responses of both services: one body shape, no tracebacks, and their OpenAPI entries.

Every error is `{"detail": "<message>"}` (the agent adds `attempts` when the infrastructure failed
mid-solve). An exception nothing else handled becomes a 500 with that shape here, *without*
re-raising: Starlette's outermost error middleware re-raises, and uvicorn then closes the
connection under the client, whose next pooled request fails with "connection reset".
"""

from __future__ import annotations

import asyncio
import logging

from fastapi import FastAPI
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.requests import Request
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from shared.wire.schemas import ErrorBody
from shared.wire.scrubbing import scrub

log = logging.getLogger("pyspatial.errors")

STATUS_MEANINGS = {
    400: "The input cannot be read (e.g. an image that does not decode).",
    401: "Missing or invalid bearer API key (only when API keys are configured).",
    404: "The scene is not known.",
    409: "The named backbone cannot run on this installation (its weights are not present); the "
    "message says what to run (`pyspatial weights pull NAME`).",
    413: "The body, an image or a count is over a limit.",
    422: "The request does not match the schema or asks for something impossible.",
    429: "Rate limit exceeded; see the Retry-After header.",
    500: "An unexpected error in the service (a bug); the message names it, the log has the details.",
    502: "A service this one depends on failed.",
    503: "Not ready, busy (see Retry-After), storage unusable, or a dependency is unreachable.",
    504: "A service this one depends on did not answer in time.",
    507: "The service has no room left to store the input (its data dir or scene store is full).",
}


def error_responses(*codes: int) -> dict[int | str, dict]:
    """The `responses=` entry of a route: each code with its meaning and the error body schema."""
    return {code: {"model": ErrorBody, "description": STATUS_MEANINGS[code]} for code in codes}


def first_validation_message(errors: list) -> str:
    first = errors[0] if errors else {"loc": (), "msg": "invalid request"}
    location = ".".join(str(part) for part in first.get("loc", ()) if part != "body")
    return f"invalid request: {location + ': ' if location else ''}{first.get('msg', 'invalid')}"


FASTAPI_BODY_ERROR = "There was an error parsing the body"
# A request the SIGTERM drain cut off: another replica can take it at once.
DRAIN_RETRY_AFTER_S = 1
# A 503 whose handler named no wait (not ready, dependency down): when a retry is worth trying.
DEFAULT_RETRY_AFTER_S = 5


class CatchAllMiddleware:
    """Unhandled exceptions become a logged 500 `{"detail": ...}`; the connection stays usable.

    Two more rules hold for every response here, so no route can forget them: a request still
    running when the drain deadline cancels it (uvicorn's `--timeout-graceful-shutdown`) gets a 503
    with Retry-After instead of uvicorn's plain-text 500, and every 503 carries Retry-After.
    """

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        response = _ResponseState()

        async def tracking_send(message: Message) -> None:
            if response.cut_off:
                return  # the drain has answered already; the work ends unheard
            if message["type"] == "http.response.start":
                response.started = True
                message = with_retry_after(message)
            await send(message)

        # The app runs in its own task, shielded: a sync route waits for its thread and cannot be
        # cancelled, yet the drain's cancellation must reach this request to answer it.
        work = asyncio.ensure_future(self._run(scope, receive, tracking_send, response))
        work.add_done_callback(_forget_outcome)
        try:
            await asyncio.shield(work)
        except asyncio.CancelledError:
            work.cancel()
            if response.started:
                raise  # too late for a status; the server closes this response
            response.cut_off = True
            log.warning("drain deadline: %s %s answered 503", scope.get("method"), scope.get("path"))
            await JSONResponse(
                {"detail": "the service is shutting down and stopped this request; retry it"},
                status_code=503,
                headers={"Retry-After": str(DRAIN_RETRY_AFTER_S)},
            )(scope, receive, send)

    async def _run(self, scope: Scope, receive: Receive, send: Send, response: _ResponseState) -> None:
        try:
            await self.app(scope, receive, send)
        except Exception as error:  # the last line of defence: everything else is mapped already
            log.exception("unhandled error in %s %s", scope.get("method"), scope.get("path"))
            if response.started or response.cut_off:  # too late for a status
                raise
            body = {"detail": f"internal error ({type(error).__name__}); the service log has the details"}
            await JSONResponse(body, status_code=500)(scope, receive, send)


class _ResponseState:
    started = False  # the app has sent its status line
    cut_off = False  # the drain answered 503 in its place


def _forget_outcome(work: asyncio.Future) -> None:
    """Read a cut-off request's outcome so asyncio does not log it as never retrieved."""
    if not work.cancelled():
        work.exception()


def with_retry_after(start: Message) -> Message:
    """A 503's `http.response.start` with Retry-After added when its handler set none."""
    headers = list(start.get("headers", []))
    if start.get("status") != 503 or any(name.lower() == b"retry-after" for name, _ in headers):
        return start
    return {**start, "headers": [*headers, (b"retry-after", str(DEFAULT_RETRY_AFTER_S).encode())]}


def install_error_shape(app: FastAPI) -> None:
    """422 in the `{"detail": str}` shape, its OpenAPI schema to match, and the catch-all 500."""

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, error: StarletteHTTPException) -> Response:
        # FastAPI answers a JSON body it cannot read for other reasons than a syntax error (bytes
        # that are not UTF-8, nesting past the parser's depth) with an undocumented 400; it is a
        # malformed body like any other: 422 with the standard body.
        if error.status_code == 400 and error.detail == FASTAPI_BODY_ERROR:
            reason = type(error.__cause__).__name__ if error.__cause__ else "unreadable"
            detail = f"invalid request: the body is not valid JSON ({reason})"
            return JSONResponse({"detail": detail}, status_code=422)
        return await http_exception_handler(request, error)

    @app.exception_handler(RequestValidationError)
    async def validation_error(_: Request, error: RequestValidationError) -> JSONResponse:
        # shape-based scrubbing: a message never echoes a credential the client put in a field
        return JSONResponse({"detail": scrub(first_validation_message(error.errors()))}, status_code=422)

    app.add_middleware(CatchAllMiddleware)
    _document_only_declared_422(app)


def _document_only_declared_422(app: FastAPI) -> None:
    """Drop FastAPI's automatic 422 (list-of-errors shape): routes that can 422 declare it."""
    build = app.openapi

    def openapi() -> dict:
        if app.openapi_schema is not None:
            return app.openapi_schema
        schema = build()
        for operations in schema.get("paths", {}).values():
            for operation in operations.values():
                automatic = operation.get("responses", {}).get("422", {})
                if "HTTPValidationError" in str(automatic):
                    del operation["responses"]["422"]
        for name in ("HTTPValidationError", "ValidationError"):
            schema.get("components", {}).get("schemas", {}).pop(name, None)
        app.openapi_schema = schema
        return schema

    app.openapi = openapi
