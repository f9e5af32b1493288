"""Request bodies and images from clients: size limits, and the HTTP errors both services give."""

from __future__ import annotations

from fastapi import FastAPI
from fastapi.responses import JSONResponse
from starlette.requests import Request

from shared.imaging import ImageError


class BodyTooLarge(ValueError):
    """The body is larger than the service accepts (HTTP 413)."""


async def read_body_limited(request: Request, limit: int) -> bytes:
    """The whole body, refusing early when Content-Length or the streamed bytes exceed `limit`.

    Chunked uploads carry no Content-Length, so the stream is counted as it arrives.
    """
    declared = request.headers.get("content-length", "")
    if declared.isdigit() and int(declared) > limit:
        raise BodyTooLarge(f"request is {declared} bytes; the limit is {limit}")
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise BodyTooLarge(f"request body exceeds the limit of {limit} bytes")
        chunks.append(chunk)
    return b"".join(chunks)


def install_input_error_handlers(app: FastAPI) -> None:
    """413 for bodies and images over a limit, 400 for images that cannot be read; the message kept."""

    @app.exception_handler(BodyTooLarge)
    async def body_too_large(_: Request, error: BodyTooLarge) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=413)

    @app.exception_handler(ImageError)
    async def image_error(_: Request, error: ImageError) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=413 if error.over_limit else 400)
