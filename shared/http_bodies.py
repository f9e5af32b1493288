"""Read request bodies without trusting the client about their size."""

from __future__ import annotations

from starlette.requests import Request


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
