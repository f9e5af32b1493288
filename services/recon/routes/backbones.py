"""`GET /v1/backbones`: which backbones this service can run, and its default."""

from __future__ import annotations

from fastapi import APIRouter

from services.recon.backbones import available_backbones
from services.recon.routes.dependencies import ServiceDep
from shared.wire.errors import error_responses

router = APIRouter(tags=["health"])


@router.get("/v1/backbones", responses=error_responses(401, 429))
async def backbones(service: ServiceDep) -> dict:
    """The registered backbones and the default one."""
    return {"default": service.settings.backbone, "available": available_backbones()}
