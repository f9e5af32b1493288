"""Error responses of both services: one body shape, no tracebacks, and their OpenAPI entries.

Every error is `{"detail": "<message>"}` (the agent adds `attempts` when the infrastructure failed
mid-solve). An exception nothing else handled becomes a 500 with that shape here, *without*
re-raising: Starlette's outermost error middleware re-raises, and uvicorn then closes the
connection under the client, whose next pooled request fails with "connection reset".
"""

from __future__ import annotations

import logging

from fastapi import FastAPI
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.requests import Request
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from shared.wire.schemas import ErrorBody

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


class CatchAllMiddleware:
    """Unhandled exceptions become a logged 500 `{"detail": ...}`; the connection stays usable."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False

        async def tracking_send(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, receive, tracking_send)
        except Exception as error:  # the last line of defence: everything else is mapped already
            log.exception("unhandled error in %s %s", scope.get("method"), scope.get("path"))
            if started:  # too late for a status; let the server close this response
                raise
            response = JSONResponse(
                {"detail": f"internal error ({type(error).__name__}); the service log has the details"},
                status_code=500,
            )
            await response(scope, receive, send)


def install_error_shape(app: FastAPI) -> None:
    """422 in the `{"detail": str}` shape, its OpenAPI schema to match, and the catch-all 500."""

    @app.exception_handler(RequestValidationError)
    async def validation_error(_: Request, error: RequestValidationError) -> JSONResponse:
        return JSONResponse({"detail": first_validation_message(error.errors())}, status_code=422)

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
