"""HTTP face of the agent service (FastAPI). Run: `pyspatial serve agent`.

`create_app` only wires: settings → the solve pipeline (on `app.state`, reached by routes through
`routes/dependencies.py`), middleware, error handlers, the page's static files, and one router per
resource (`services/agent/routes/`). What a solve does lives in `pipeline.py`, independent of HTTP.
"""

from __future__ import annotations

import logging
from contextlib import asynccontextmanager

import anyio
from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette_compress import CompressMiddleware

from services.agent.errors import SolveError
from services.agent.infrastructure import InfrastructureFailure, recon_error_status, recon_retry_after
from services.agent.llm import LLMError
from services.agent.pipeline import SolvePipeline
from services.agent.routes import ROUTERS
from services.agent.sandbox.jail import announce, remove_stale_workdirs
from services.agent.sandbox_budget import SandboxBusy
from services.agent.web_page import WEB_DIR, SecurityHeaders, build_page
from shared.wire.access import docs_urls, install_access_control
from shared.wire.bodies import install_input_error_handlers
from shared.wire.client import ServiceError, ServiceUnreachable
from shared.wire.errors import install_error_shape
from shared.wire.scrubbing import install_log_scrubbing
from shared.wire.settings import AgentSettings

log = logging.getLogger("pyspatial.agent")


def create_app(settings: AgentSettings | None = None) -> FastAPI:
    settings = settings or AgentSettings()
    app = FastAPI(
        title="pySpatial agent service",
        version="0.1.0",
        description="Answers spatial questions about images by writing and running pySpatial programs.",
        lifespan=_lifespan,
        redirect_slashes=False,  # "/v1/scenes/<id>%2F" must be a 404, not a redirect elsewhere
        **docs_urls(settings),
    )
    app.state.settings = settings
    # The keys the agent sends (recon's, the models') are scrubbed from its logs like its own.
    sent_keys = (settings.recon_api_key, settings.code_model_api_key, settings.answer_model_api_key)
    install_log_scrubbing([key.get_secret_value() for key in sent_keys if key is not None])
    app.state.pipeline = SolvePipeline(settings)
    app.state.web_page = build_page()
    install_error_shape(app)
    install_access_control(app, settings)
    app.add_exception_handler(SolveError, _solve_error)
    install_input_error_handlers(app)
    app.add_exception_handler(ServiceError, _recon_error)
    app.add_exception_handler(ServiceUnreachable, _recon_error)
    app.add_exception_handler(InfrastructureFailure, _infrastructure_failure)
    app.add_exception_handler(LLMError, _model_error)
    app.add_exception_handler(SandboxBusy, _sandbox_busy)
    for router in ROUTERS:
        app.include_router(router)
    app.mount("/web", StaticFiles(directory=WEB_DIR), name="web")
    # Outermost: every response (errors included) gets the security headers, then is compressed
    # (zstd, brotli or gzip as the client accepts; the solve's event stream is flushed per event).
    app.add_middleware(SecurityHeaders, page_policy=app.state.web_page.content_security_policy)
    app.add_middleware(CompressMiddleware)
    return app


async def _solve_error(_: Request, error: SolveError) -> JSONResponse:
    return JSONResponse({"detail": error.message}, status_code=error.status_code)


async def _recon_error(_: Request, error: ServiceError | ServiceUnreachable) -> JSONResponse:
    """Recon failed or refused our call: its 4xx about the client's input, else 502/503/504."""
    status, detail = recon_error_status(error)
    return JSONResponse({"detail": detail}, status_code=status, headers=recon_retry_after(error))


async def _infrastructure_failure(_: Request, error: InfrastructureFailure) -> JSONResponse:
    log.error("solve stopped: %s", error.message)
    attempts = [attempt.model_dump() for attempt in error.attempts]
    return JSONResponse({"detail": error.message, "attempts": attempts}, status_code=error.status_code)


async def _sandbox_busy(_: Request, error: SandboxBusy) -> JSONResponse:
    headers = {"Retry-After": str(error.retry_after_s)}
    return JSONResponse({"detail": str(error)}, status_code=503, headers=headers)


async def _model_error(_: Request, error: LLMError) -> JSONResponse:
    return JSONResponse({"detail": f"language model: {error}"}, status_code=502)


@asynccontextmanager
async def _lifespan(app: FastAPI):
    pipeline: SolvePipeline = app.state.pipeline
    stale = remove_stale_workdirs()
    if stale:
        log.warning("sandbox: removed %d directories left by a previous run", stale)
    announce(await anyio.to_thread.run_sync(lambda: pipeline.jail))
    log.warning(
        "agent service: recon=%s, code model=%s, answer model=%s",
        app.state.settings.recon_url,
        pipeline.code_model_name,
        pipeline.answer_model_name,
    )
    yield
    pipeline.close()
