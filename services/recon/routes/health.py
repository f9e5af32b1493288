"""Probes for kubelets and load balancers: `/healthz` (the process answers) and `/readyz`.

Both stay open without an API key (shared/wire/access.py guards `/v1/` only). `/readyz` is a 503
with the reason while the backbone cannot run or the data dir cannot be written; an unreachable
Redis is only a warning, since the service then serves from its in-process cache.
"""

from __future__ import annotations

from fastapi.responses import JSONResponse

from services.recon.offload import run_cpu
from services.recon.routes.dependencies import ServiceDep
from shared.wire.probes import health_router, not_ready
from shared.wire.schemas import Readiness

router = health_router()  # GET /healthz; GET /readyz below


@router.get("/readyz", response_model=Readiness, responses=not_ready(Readiness, "backbone_detail"))
async def readyz(service: ServiceDep) -> JSONResponse:
    backbone_ready, detail = service.backbone_status()
    cache_mode = await service.cache.check()
    warnings = []
    if cache_mode == "redis-unavailable":
        warnings.append(
            "Redis is unreachable: serving from the in-process cache "
            f"({service.cache.pending_writes} writes pending)"
        )
    storage = await run_cpu(service.storage_status)
    warnings.extend(storage.warnings)
    ready = backbone_ready and storage.ok
    body = Readiness(
        ready=ready,
        backbone=service.settings.backbone,
        backbone_ready=backbone_ready,
        backbone_detail=detail,
        cache=cache_mode,
        storage=storage.detail,
        warnings=warnings,
    )
    return JSONResponse(body.model_dump(), status_code=200 if ready else 503)
