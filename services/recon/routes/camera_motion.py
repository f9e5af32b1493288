"""`POST /v1/camera-motion`: how the camera moved between pairs of views, in words and numbers."""

from __future__ import annotations

from fastapi import APIRouter, Request

from services.recon.disconnect import until_disconnected
from services.recon.routes.dependencies import ServiceDep, TenantDep
from shared.wire.errors import error_responses
from shared.wire.schemas import CameraMotionItem, CameraMotionRequest, CameraMotionResponse

router = APIRouter(tags=["tools"])


@router.post(
    "/v1/camera-motion",
    response_model=CameraMotionResponse,
    responses=error_responses(401, 404, 409, 422, 429, 503),
)
async def camera_motion(
    http: Request, request: CameraMotionRequest, service: ServiceDep, tenant: TenantDep
) -> CameraMotionResponse:
    """Per pair of views a description, or (described = false) why there is none."""
    recon, motions, scale = await until_disconnected(
        http,
        service.camera_motion(
            request.scene_id, request.requested_pairs(), request.backbone, request.target, tenant
        ),
    )
    items = [CameraMotionItem.model_validate(numbered_from_one(m.to_dict())) for m in motions]
    return CameraMotionResponse(
        scene_id=request.scene_id,
        backbone=recon.backbone,
        motions=items,
        text="\n".join(item.sentence for item in items),
        scene_scale=scale,
        warnings=recon.warnings,
    )


def numbered_from_one(motion: dict) -> dict:
    """A pair's motion as the wire names it: its views numbered from 1 (the geometry indexes from 0)."""
    return {**motion, "from_view": motion["from_view"] + 1, "to_view": motion["to_view"] + 1}
