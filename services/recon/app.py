"""HTTP face of the reconstruction service (FastAPI). Run: `pyspatial serve recon`.

`create_app` only wires: settings → the service and the upload parser (on `app.state`, reached by
routes through `routes/dependencies.py`), middleware, error handlers, and one router per resource
(`services/recon/routes/`). What the service does lives in `service.py`, independent of HTTP.
"""

from __future__ import annotations

import logging
import threading
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse

from services.recon.backbone_menu import backbone_menu
from services.recon.errors import ReconServiceError
from services.recon.routes import ROUTERS
from services.recon.service import ReconService
from services.recon.uploads import SceneUploads
from shared.wire.access import docs_urls, install_access_control
from shared.wire.bodies import install_input_error_handlers
from shared.wire.errors import install_error_shape
from shared.wire.settings import ReconSettings

log = logging.getLogger("pyspatial.recon")


def create_app(settings: ReconSettings | None = None) -> FastAPI:
    settings = settings or ReconSettings()
    app = FastAPI(
        title="pySpatial reconstruction service",
        version="0.1.0",
        description="Reconstructs scenes from images and renders, measures and describes them.",
        lifespan=_lifespan,
        redirect_slashes=False,  # "/v1/scenes/<id>%2F" must be a 404, not a redirect elsewhere
        **docs_urls(settings),
    )
    app.state.service = ReconService(settings)
    app.state.uploads = SceneUploads(settings)
    install_error_shape(app)
    install_access_control(app, settings)
    app.add_exception_handler(ReconServiceError, _service_error)
    install_input_error_handlers(app)
    for router in ROUTERS:
        app.include_router(router)
    return app


async def _service_error(_: Request, error: ReconServiceError) -> JSONResponse:
    """Each service error answers its own status with its message, and Retry-After when busy."""
    headers = {"Retry-After": str(error.retry_after_s)} if error.retry_after_s else None
    return JSONResponse({"detail": error.message}, status_code=error.status_code, headers=headers)


@asynccontextmanager
async def _lifespan(app: FastAPI):
    service: ReconService = app.state.service
    await _log_start_up(service)
    # The backbone menu needs torch (for the device) and reads checkpoint headers: do that now, off
    # the event loop and without delaying start-up, so the first /v1/backbones answers quickly.
    threading.Thread(
        target=backbone_menu, args=(service.settings,), name="warm backbone menu", daemon=True
    ).start()
    collector = service.start_store_gc()
    yield
    if collector is not None:
        collector.stop()
    app.state.uploads.close()
    # SIGTERM: uvicorn stops accepting and gives requests `drain_s` (--timeout-graceful-shutdown);
    # then queued reconstructions are dropped and running ones stopped, releasing their leases
    # for another replica (the reconstruction threads are daemons: they do not delay the exit).
    await service.jobs.drain(timeout_s=1.0)
    await service.cache.close()


async def _log_start_up(service: ReconService) -> None:
    """What runs and what does not, said once at start-up."""
    settings = service.settings
    ready, detail = service.backbone_status()
    log.warning(
        "recon service: backbone=%s (%s), cache=%s, data=%s, store=%s",
        settings.backbone,
        detail,
        await service.cache.check(),
        settings.data_dir,
        settings.store_dir or "none (Redis and the data dir only)",
    )
    if not ready:  # no silent fallback: the service answers, /readyz says 503 and why
        log.error("backbone %s is NOT ready: %s", settings.backbone, detail)
    storage = service.store.check_writable()
    if storage:
        log.error("data dir is NOT writable: %s", storage)
