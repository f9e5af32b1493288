"""What a route may ask for: the app's one `SolvePipeline` and its settings (on `app.state`), and the
recon client of the request's tenant (the access middleware found it from the caller's key)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any

from fastapi import Depends, Request

from services.agent.pipeline import SolvePipeline
from shared.wire.access import request_tenant
from shared.wire.client import ReconClient
from shared.wire.settings import AgentSettings


def _on_app_state(name: str) -> Callable[[Request], Any]:
    """A dependency that reads `app.state.<name>` (create_app puts it there)."""

    def read(request: Request) -> Any:
        return getattr(request.app.state, name)

    return read


def tenant_recon(request: Request) -> ReconClient:
    """The pipeline's recon client naming this caller's tenant: recon serves that tenant's scenes."""
    return request.app.state.pipeline.recon_for(request_tenant(request.scope))


def tenant(request: Request) -> str:
    return request_tenant(request.scope)


PipelineDep = Annotated[SolvePipeline, Depends(_on_app_state("pipeline"))]
SettingsDep = Annotated[AgentSettings, Depends(_on_app_state("settings"))]
TenantDep = Annotated[str, Depends(tenant)]
TenantReconDep = Annotated[ReconClient, Depends(tenant_recon)]
