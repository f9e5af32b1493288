"""The liveness probe both services answer alike: `GET /healthz`, the process is up and serving.

Each service's own `routes/health.py` starts from `health_router()` and adds its `/readyz` (what
"ready" means differs: recon's backbone and storage, the agent's recon and sandbox).
"""

from __future__ import annotations

from fastapi import APIRouter

liveness = APIRouter()  # untagged: the including router gives the tag


@liveness.get("/healthz")
async def healthz() -> dict:
    return {"status": "ok"}


def health_router() -> APIRouter:
    """A service's `health` router, with `/healthz` in it; the service adds its `/readyz`."""
    router = APIRouter(tags=["health"])
    router.include_router(liveness)
    return router


def not_ready(model: type, field: str) -> dict[int | str, dict]:
    """The 503 of a `/readyz` route (`responses=`): a body of `model` whose `field` says why."""
    return {503: {"model": model, "description": f"Not ready; `{field}` says why."}}


__all__ = ["health_router", "liveness", "not_ready"]
