"""What a route may ask for: the app's one `ReconService` and its upload parser (on `app.state`), and
the request's tenant (found by the access middleware from the key)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from services.recon.service import ReconService
from services.recon.uploads import SceneUploads
from shared.wire.access import request_tenant


def recon_service(request: Request) -> ReconService:
    return request.app.state.service


def scene_uploads(request: Request) -> SceneUploads:
    return request.app.state.uploads


def tenant(request: Request) -> str:
    return request_tenant(request.scope)


ServiceDep = Annotated[ReconService, Depends(recon_service)]
UploadsDep = Annotated[SceneUploads, Depends(scene_uploads)]
TenantDep = Annotated[str, Depends(tenant)]
