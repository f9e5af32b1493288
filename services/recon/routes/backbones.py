"""`GET /v1/backbones`: every backbone, whether it can run here now (and why not), its units and
device; the default, what `auto` stands for now, and the names a request may use."""

from __future__ import annotations

from dataclasses import asdict

import anyio
from fastapi import APIRouter

from services.recon.backbone_menu import AUTO, backbone_menu, resolve_auto
from services.recon.routes.dependencies import ServiceDep
from shared.wire.errors import error_responses
from shared.wire.schemas import BackboneMenu

router = APIRouter(tags=["health"])


@router.get("/v1/backbones", response_model=BackboneMenu, responses=error_responses(401, 429))
async def backbones(service: ServiceDep) -> BackboneMenu:
    """Learned backbones are available when their checkpoint is present and fits; nothing is loaded."""
    settings = service.settings
    menu = await anyio.to_thread.run_sync(backbone_menu, settings)  # reads checkpoint headers once
    auto = await anyio.to_thread.run_sync(resolve_auto, settings)
    return BackboneMenu(
        default=settings.backbone,
        auto=auto,
        backbones=[asdict(entry) for entry in menu],
        available=[AUTO, *(entry.name for entry in menu if entry.available)],
    )
