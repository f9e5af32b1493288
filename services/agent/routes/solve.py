"""`POST /v1/solve`: a question about photos (or a scene), answered as JSON or as an event stream.

The body is JSON (`SolveRequest`) or multipart (files `images` and text fields of the same names),
read within `PYSPATIAL_MAX_REQUEST_BYTES` and parsed here once into a `SolveRequest`. With
`Accept: text/event-stream` the stages stream as SSE (services/agent/solve_stream.py).
"""

from __future__ import annotations

import base64
import weakref

import anyio
import pydantic_core
from fastapi import APIRouter, Request, Response
from pydantic import ValidationError
from starlette.datastructures import UploadFile
from starlette.formparsers import MultiPartException, MultiPartParser

from services.agent.cancellation import Cancellation, SolveCancelled, cancel_when_client_leaves
from services.agent.errors import SolveError
from services.agent.routes.dependencies import PipelineDep, SettingsDep, TenantDep
from services.agent.solve_stream import event_stream, wants_event_stream
from shared.imaging.codecs import check_upload_pixels, decode_base64
from shared.wire.bodies import limited_stream, read_body_limited
from shared.wire.errors import error_responses, first_validation_message
from shared.wire.schemas import SolveRequest, SolveResponse
from shared.wire.settings import AgentSettings

MULTIPART_JSON_FIELDS = {"extrinsics", "intrinsics"}  # multipart fields that carry JSON, when accepted

_SOLVE_DOC = {
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {"schema": SolveRequest.model_json_schema()},
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "properties": {
                        "images": {"type": "array", "items": {"type": "string", "format": "binary"}},
                        "question": {"type": "string"},
                        "scene_id": {"type": "string"},
                        "backbone": {"type": "string"},
                        "max_repairs": {"type": "integer"},
                    },
                    "required": ["question"],
                }
            },
        },
    },
    "responses": {
        "200": {
            "content": {
                "text/event-stream": {
                    "schema": {
                        "type": "string",
                        "description": "With Accept: text/event-stream: SSE events `stage` (StageEvent), "
                        "then `result` (ResultEvent) or `error` (ErrorEvent).",
                    }
                }
            }
        }
    },
}

router = APIRouter(tags=["solve"])


@router.post(
    "/v1/solve",
    response_model=SolveResponse,
    openapi_extra=_SOLVE_DOC,
    responses=error_responses(400, 401, 404, 409, 413, 422, 429, 502, 503, 504),
)
async def solve(
    request: Request, pipeline: PipelineDep, settings: SettingsDep, tenant: TenantDep
) -> SolveResponse:
    """Answer a question; with `Accept: text/event-stream`, stream the stages (SSE) then the result."""
    body = await _read_solve_request(request, settings)
    files = [decode_base64(text, f"image {i + 1}") for i, text in enumerate(body.images or [])]
    if len(files) > settings.max_images:
        raise SolveError(422, f"{len(files)} images; at most {settings.max_images}")
    # The pixel budget from the headers, before the solve starts and before any pixel is decoded.
    await anyio.to_thread.run_sync(
        lambda: check_upload_pixels(
            files,
            max_bytes=settings.max_image_bytes,
            max_pixels=settings.max_image_pixels,
            max_total_pixels=settings.max_request_pixels,
        )
    )
    cancellation = Cancellation()  # fired when the client goes away: the solve's work stops
    ticket = pipeline.sandbox_gate.admit()  # SandboxBusy (503 + Retry-After) before anything streams

    def run(progress=None) -> SolveResponse:
        given = (body.question, files or None, body.scene_id, body.backbone, body.max_repairs)
        try:
            return pipeline.solve(*given, progress, cancellation, tenant=tenant)
        finally:
            ticket.release()

    weakref.finalize(run, ticket.release)  # a stream dropped before it started frees its ticket too
    if wants_event_stream(request.headers.get("accept", "")):
        return event_stream(run, cancellation)
    try:
        return await cancel_when_client_leaves(request.receive, anyio.to_thread.run_sync(run), cancellation)
    except SolveCancelled:
        return Response(status_code=499)  # nginx's "client closed request": only the logs read it
    finally:
        ticket.release()  # also when the solve never started (the client left first)


async def _read_solve_request(request: Request, settings: AgentSettings) -> SolveRequest:
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > settings.max_request_bytes:
        raise SolveError(413, f"request is {declared} bytes; the limit is {settings.max_request_bytes}")
    content_type = request.headers.get("content-type", "")
    try:
        if content_type.startswith("application/json"):
            return SolveRequest.model_validate_json(
                await read_body_limited(request, settings.max_request_bytes)
            )
        if content_type.startswith("multipart/form-data"):
            return await _read_multipart(request, settings)
    except ValidationError as error:
        raise SolveError(422, first_validation_message(error.errors())) from error
    raise SolveError(422, "send JSON {question, images|scene_id} or multipart/form-data with 'images' files")


async def _read_multipart(request: Request, settings: AgentSettings) -> SolveRequest:
    # The parser reads a counted stream: a chunked body stops at the byte limit (413), and the
    # files spooled to disk meanwhile can never hold more than that limit. One file too many stops
    # the parser at once.
    parser = MultiPartParser(
        request.headers,
        limited_stream(request, settings.max_request_bytes),
        max_files=settings.max_images,
        max_fields=16,
    )
    try:
        form = await parser.parse()
    except MultiPartException as error:
        if "Too many files" in error.message:
            raise SolveError(422, f"too many images; at most {settings.max_images}") from error
        raise SolveError(422, f"could not parse the multipart request: {error.message}") from error
    try:
        return await _solve_request_from(form, settings)
    finally:
        await form.close()


async def _solve_request_from(form, settings: AgentSettings) -> SolveRequest:
    images = []
    for item in form.getlist("images"):
        if not isinstance(item, UploadFile):
            raise SolveError(422, "field 'images' must carry files")
        if item.size is not None and item.size > settings.max_image_bytes:
            raise SolveError(
                413, f"{item.filename} is {item.size} bytes; the limit is {settings.max_image_bytes}"
            )
        images.append(base64.b64encode(await item.read()).decode("ascii"))
    return SolveRequest.model_validate({**_text_fields(form), "images": images or None})


def _text_fields(form) -> dict:
    """The form's text fields; unknown names are left for the schema to reject (a 422)."""
    fields = {}
    for name, value in form.multi_items():
        if name == "images" or value == "":
            continue
        if not isinstance(value, str):
            raise SolveError(422, f"field {name!r} must be text, not a file")
        if name in fields:
            raise SolveError(422, f"field {name!r} is given more than once")
        fields[name] = value
    for name in MULTIPART_JSON_FIELDS & fields.keys() & SolveRequest.model_fields.keys():
        try:  # pydantic's parser has a nesting limit: deep nesting is a ValueError, not a crash
            fields[name] = pydantic_core.from_json(fields[name])
        except ValueError as error:
            raise SolveError(422, f"field {name!r} must be JSON: {error}") from error
    return fields
