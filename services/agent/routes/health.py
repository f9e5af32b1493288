"""Probes for kubelets and load balancers: `/healthz` (the process answers) and `/readyz`.

`/readyz` is ready when the recon service is, answers within `PYSPATIAL_READINESS_TIMEOUT_S`, and
is a 503 with `reason` when recon is down, hung, not ready, refuses the agent's key, or when the
program sandbox cannot run programs.
"""

from __future__ import annotations

import anyio
from fastapi.responses import JSONResponse

from services.agent.routes.dependencies import PipelineDep, SettingsDep
from shared.wire.client import ReconClient, ServiceError, ServiceUnreachable
from shared.wire.probes import health_router, not_ready
from shared.wire.schemas import AgentReadiness, Readiness, SandboxStatus

router = health_router()  # GET /healthz; GET /readyz below


@router.get("/readyz", response_model=AgentReadiness, responses=not_ready(AgentReadiness, "reason"))
async def readyz(pipeline: PipelineDep, settings: SettingsDep) -> JSONResponse:
    """Ready when the recon service is; answers within `PYSPATIAL_READINESS_TIMEOUT_S`."""
    recon, reason = await _recon_readiness(pipeline.readiness_probe(), settings.readiness_timeout_s)
    recon_ok = recon is not None and reason is None
    sandbox = pipeline.jail
    if recon_ok and not sandbox.runs_programs:
        reason = f"generated programs cannot run: {sandbox.detail}"
    body = AgentReadiness(
        ready=recon_ok and sandbox.runs_programs,
        reason=reason,
        recon=recon.model_dump() if recon is not None else None,
        sandbox=SandboxStatus(**sandbox.summary()),
        code_model=pipeline.code_model_name,
        answer_model=pipeline.answer_model_name,
    )
    return JSONResponse(body.model_dump(), status_code=200 if body.ready else 503)


async def _recon_readiness(recon: ReconClient, timeout: float) -> tuple[Readiness | None, str | None]:
    """Recon's readiness when it answered (None otherwise), and why the agent is not ready (None: it is)."""
    try:
        with anyio.fail_after(2 * timeout + 1.0):  # the client's own timeouts should fire first
            readiness, refused = await anyio.to_thread.run_sync(
                _check_recon, recon, timeout, abandon_on_cancel=True
            )
    except TimeoutError:
        return None, f"the reconstruction service did not answer /readyz within {timeout} s"
    except (ServiceUnreachable, ServiceError) as error:
        return None, str(error)
    if not readiness.ready:
        return readiness, f"the reconstruction service is not ready: {readiness.backbone_detail}"
    if refused is not None:
        return readiness, f"the reconstruction service refuses the agent's key: {refused}"
    return readiness, None


def _check_recon(recon: ReconClient, timeout: float) -> tuple[Readiness, str | None]:
    """Recon's readiness, and why it refuses our key (its /readyz is open, its API may not be)."""
    readiness = recon.readyz(timeout)
    if readiness.ready:
        try:
            recon.backbones(timeout=timeout)
        except ServiceError as error:
            if error.refused_key:
                return readiness, error.message
    return readiness, None
