"""Request bodies and images from clients: size limits, and the HTTP errors both services give."""

from __future__ import annotations

from collections.abc import AsyncIterator

from fastapi import FastAPI
from fastapi.responses import JSONResponse
from starlette.requests import Request

from shared.imaging.codecs import ImageError


class BodyTooLarge(ValueError):
    """The body is larger than the service accepts (HTTP 413)."""


def check_declared_length(request: Request, limit: int) -> None:
    declared = request.headers.get("content-length", "")
    if declared.isdigit() and int(declared) > limit:
        raise BodyTooLarge(f"request is {declared} bytes; the limit is {limit}")


async def limited_stream(request: Request, limit: int) -> AsyncIterator[bytes]:
    """The body as it arrives, raising BodyTooLarge as soon as more than `limit` bytes came.

    Chunked uploads carry no Content-Length, so the stream itself is counted; parsers that consume
    this stream (JSON, multipart) can never see more than `limit` bytes.
    """
    check_declared_length(request, limit)
    size = 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise BodyTooLarge(f"request body exceeds the limit of {limit} bytes")
        yield chunk


async def read_body_limited(request: Request, limit: int) -> bytes:
    """The whole body, refusing early when Content-Length or the streamed bytes exceed `limit`."""
    return b"".join([chunk async for chunk in limited_stream(request, limit)])


def install_input_error_handlers(app: FastAPI) -> None:
    """413 for bodies and images over a limit, 400 for images that cannot be read; the message kept."""

    @app.exception_handler(BodyTooLarge)
    async def body_too_large(_: Request, error: BodyTooLarge) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=413)

    @app.exception_handler(ImageError)
    async def image_error(_: Request, error: ImageError) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=413 if error.over_limit else 400)
