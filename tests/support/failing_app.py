"""A tiny app with a route that fails unexpectedly, dressed like our services (shared.wire.errors).

Our services have no known route that raises an unhandled error; this is how the catch-all's
behaviour is tested under a real uvicorn: a JSON 500 without a traceback, the connection kept.
"""

from __future__ import annotations

from fastapi import FastAPI

from shared.wire.errors import install_error_shape


def create_app() -> FastAPI:
    app = FastAPI()
    install_error_shape(app)

    @app.get("/boom")
    async def boom() -> dict:
        raise RuntimeError("secret internal state that must not reach the client")

    @app.get("/healthz")
    async def healthz() -> dict:
        return {"status": "ok"}

    return app
