"""HTTP face of the agent service (FastAPI). Run: `pyspatial serve agent`."""

from __future__ import annotations

import logging
from contextlib import asynccontextmanager

import anyio
from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from starlette.datastructures import UploadFile

from services.agent.llm import LLMError
from services.agent.pipeline import SolveError, SolvePipeline
from services.agent.sandbox.jail import announce, remove_stale_workdirs
from services.agent.solve_stream import event_stream, wants_event_stream
from services.agent.web_routes import install_web_routes
from shared.client import ServiceError, ServiceUnreachable
from shared.http_bodies import install_input_error_handlers, read_body_limited
from shared.imaging import decode_base64
from shared.schemas import SolveRequest, SolveResponse
from shared.settings import AgentSettings

log = logging.getLogger("pyspatial.agent")

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


def create_app(settings: AgentSettings | None = None) -> FastAPI:
    settings = settings or AgentSettings()
    pipeline = SolvePipeline(settings)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        stale = remove_stale_workdirs()
        if stale:
            log.warning("sandbox: removed %d directories left by a previous run", stale)
        announce(await anyio.to_thread.run_sync(lambda: pipeline.jail))
        log.warning(
            "agent service: recon=%s, code model=%s, answer model=%s",
            settings.recon_url,
            pipeline.code_model_name,
            pipeline.answer_model_name,
        )
        yield
        pipeline.close()

    app = FastAPI(
        title="pySpatial agent service",
        version="0.1.0",
        description="Answers spatial questions about images by writing and running pySpatial programs.",
        lifespan=lifespan,
    )

    @app.exception_handler(SolveError)
    async def solve_error(_: Request, error: SolveError) -> JSONResponse:
        return JSONResponse({"detail": error.message}, status_code=error.status_code)

    install_input_error_handlers(app)

    @app.exception_handler(ServiceError)
    async def recon_error(_: Request, error: ServiceError) -> JSONResponse:
        status = error.status_code if error.status_code < 500 else 502
        return JSONResponse({"detail": f"reconstruction service: {error.message}"}, status_code=status)

    @app.exception_handler(ServiceUnreachable)
    async def recon_unreachable(_: Request, error: ServiceUnreachable) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=503)

    @app.exception_handler(LLMError)
    async def model_error(_: Request, error: LLMError) -> JSONResponse:
        return JSONResponse({"detail": f"language model: {error}"}, status_code=502)

    @app.get("/healthz", tags=["health"])
    async def healthz() -> dict:
        return {"status": "ok"}

    @app.get("/readyz", tags=["health"])
    async def readyz() -> JSONResponse:
        try:
            recon = await anyio.to_thread.run_sync(pipeline.recon.readyz)
            recon_ok, recon_detail = recon.ready, recon.model_dump()
        except (ServiceUnreachable, ValueError) as error:
            recon_ok, recon_detail = False, str(error)
        sandbox = pipeline.jail
        body = {
            "ready": recon_ok and sandbox.runs_programs,
            "recon": recon_detail,
            "sandbox": sandbox.summary(),
            "code_model": pipeline.code_model_name,
            "answer_model": pipeline.answer_model_name,
        }
        return JSONResponse(body, status_code=200 if body["ready"] else 503)

    @app.post("/v1/solve", tags=["solve"], response_model=SolveResponse, openapi_extra=_SOLVE_DOC)
    async def solve(request: Request) -> SolveResponse:
        """Answer a question; with `Accept: text/event-stream`, stream the stages (SSE) then the result."""
        body = await _read_solve_request(request, settings)
        files = [decode_base64(text, f"image {i + 1}") for i, text in enumerate(body.images or [])]
        if wants_event_stream(request.headers.get("accept", "")):
            return event_stream(
                lambda progress: pipeline.solve(
                    body.question, files or None, body.scene_id, body.backbone, body.max_repairs, progress
                )
            )
        return await anyio.to_thread.run_sync(
            pipeline.solve, body.question, files or None, body.scene_id, body.backbone, body.max_repairs
        )

    install_web_routes(app, pipeline)
    return app


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
        first = error.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise SolveError(422, f"invalid request: {where + ': ' if where else ''}{first['msg']}") from error
    raise SolveError(422, "send JSON {question, images|scene_id} or multipart/form-data with 'images' files")


async def _read_multipart(request: Request, settings: AgentSettings) -> SolveRequest:
    import base64

    try:
        form = await request.form(max_files=settings.max_images + 1, max_fields=16)
    except Exception as error:  # starlette raises several parser errors for malformed bodies
        raise SolveError(422, f"could not parse the multipart request: {error}") from error
    images = []
    for item in form.getlist("images"):
        if not isinstance(item, UploadFile):
            raise SolveError(422, "field 'images' must carry files")
        if item.size is not None and item.size > settings.max_image_bytes:
            raise SolveError(
                413, f"{item.filename} is {item.size} bytes; the limit is {settings.max_image_bytes}"
            )
        images.append(base64.b64encode(await item.read()).decode("ascii"))
    fields = {k: form.get(k) for k in ("question", "scene_id", "backbone", "max_repairs") if form.get(k)}
    return SolveRequest.model_validate({**fields, "images": images or None})
