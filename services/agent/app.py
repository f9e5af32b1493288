"""HTTP face of the agent service (FastAPI). Run: `pyspatial serve agent`."""

from __future__ import annotations

import logging
from contextlib import asynccontextmanager

import anyio
import pydantic_core
from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from starlette.datastructures import UploadFile

from services.agent.errors import SolveError
from services.agent.infrastructure import InfrastructureFailure, recon_error_status
from services.agent.llm import LLMError
from services.agent.pipeline import SolvePipeline
from services.agent.sandbox.jail import announce, remove_stale_workdirs
from services.agent.solve_stream import event_stream, wants_event_stream
from services.agent.web_routes import install_web_routes
from shared.imaging.codecs import decode_base64
from shared.wire.access import docs_urls, install_access_control
from shared.wire.bodies import install_input_error_handlers, read_body_limited
from shared.wire.client import ReconClient, ServiceError, ServiceUnreachable
from shared.wire.errors import error_responses, first_validation_message, install_error_shape
from shared.wire.schemas import AgentReadiness, Readiness, SandboxStatus, SolveRequest, SolveResponse
from shared.wire.settings import AgentSettings

log = logging.getLogger("pyspatial.agent")

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
        redirect_slashes=False,  # "/v1/scenes/<id>%2F" must be a 404, not a redirect elsewhere
        **docs_urls(settings),
    )
    install_error_shape(app)
    install_access_control(app, settings)

    @app.exception_handler(SolveError)
    async def solve_error(_: Request, error: SolveError) -> JSONResponse:
        return JSONResponse({"detail": error.message}, status_code=error.status_code)

    install_input_error_handlers(app)

    @app.exception_handler(ServiceError)
    @app.exception_handler(ServiceUnreachable)
    async def recon_error(_: Request, error: ServiceError | ServiceUnreachable) -> JSONResponse:
        status, detail = recon_error_status(error)
        return JSONResponse({"detail": detail}, status_code=status)

    @app.exception_handler(InfrastructureFailure)
    async def infrastructure_failure(_: Request, error: InfrastructureFailure) -> JSONResponse:
        log.error("solve stopped: %s", error.message)
        attempts = [attempt.model_dump() for attempt in error.attempts]
        return JSONResponse({"detail": error.message, "attempts": attempts}, status_code=error.status_code)

    @app.exception_handler(LLMError)
    async def model_error(_: Request, error: LLMError) -> JSONResponse:
        return JSONResponse({"detail": f"language model: {error}"}, status_code=502)

    @app.get("/healthz", tags=["health"])
    async def healthz() -> dict:
        return {"status": "ok"}

    @app.get(
        "/readyz",
        tags=["health"],
        response_model=AgentReadiness,
        responses={503: {"model": AgentReadiness, "description": "Not ready; `reason` says why."}},
    )
    async def readyz() -> JSONResponse:
        """Ready when the recon service is; answers within `PYSPATIAL_READINESS_TIMEOUT_S`."""
        timeout = settings.readiness_timeout_s
        reason = None
        try:
            with anyio.fail_after(2 * timeout + 1.0):  # the client's own timeouts should fire first
                recon, refused = await anyio.to_thread.run_sync(
                    _check_recon, pipeline.recon, timeout, abandon_on_cancel=True
                )
            recon_ok, recon_detail = recon.ready and refused is None, recon.model_dump()
            if not recon.ready:
                reason = f"the reconstruction service is not ready: {recon.backbone_detail}"
            elif refused is not None:
                reason = f"the reconstruction service refuses the agent's key: {refused}"
        except TimeoutError:
            recon_ok, recon_detail = False, None
            reason = f"the reconstruction service did not answer /readyz within {timeout} s"
        except (ServiceUnreachable, ServiceError) as error:
            recon_ok, recon_detail = False, None
            reason = str(error)
        sandbox = pipeline.jail
        if recon_ok and not sandbox.runs_programs:
            reason = f"generated programs cannot run: {sandbox.detail}"
        body = AgentReadiness(
            ready=recon_ok and sandbox.runs_programs,
            reason=reason,
            recon=recon_detail,
            sandbox=SandboxStatus(**sandbox.summary()),
            code_model=pipeline.code_model_name,
            answer_model=pipeline.answer_model_name,
        )
        return JSONResponse(body.model_dump(), status_code=200 if body.ready else 503)

    @app.post(
        "/v1/solve",
        tags=["solve"],
        response_model=SolveResponse,
        openapi_extra=_SOLVE_DOC,
        responses=error_responses(400, 401, 404, 413, 422, 429, 502, 503, 504),
    )
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


def _check_recon(recon: ReconClient, timeout: float) -> tuple[Readiness, str | None]:
    """Recon's readiness, and why it refuses our key (its /readyz is open, its API may not be)."""
    readiness = recon.readyz(timeout)
    if readiness.ready:
        try:
            recon.backbones(timeout=timeout)
        except ServiceError as error:
            if error.status_code in (401, 403):
                return readiness, error.message
    return readiness, None


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
