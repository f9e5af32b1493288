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
    items = [CameraMotionItem.model_validate(as_wire(m.to_dict())) for m in motions]
    return CameraMotionResponse(
        scene_id=request.scene_id,
        backbone=recon.backbone,
        motions=items,
        text="\n".join(item.sentence for item in items),
        scene_scale=scale,
        warnings=recon.warnings,
    )


def as_wire(motion: dict) -> dict:
    """A pair's motion in the API's conventions: views numbered from 1 and every horizontal angle
    left-positive. The geometry indexes views from 0 and measures a step's heading clockwise
    (0 forward, +90 right, as its compass names read); turns are left-positive on both sides."""
    wire = {**motion, "from_view": motion["from_view"] + 1, "to_view": motion["to_view"] + 1}
    if wire.get("angle_deg") is not None:
        wire["angle_deg"] = _left_positive(wire["angle_deg"])
    over = wire.get("over_focal")
    if isinstance(over, dict):
        over = wire["over_focal"] = {**over, "heading_range_deg": _mirrored(over.get("heading_range_deg"))}
        quantities = dict(over.get("quantities") or {})
        if isinstance(quantities.get("direction"), dict):
            direction = quantities["direction"]
            quantities["direction"] = {**direction, "range": _mirrored(direction.get("range"))}
            over["quantities"] = quantities
    return wire


def _left_positive(clockwise_deg: float) -> float:
    turned = -float(clockwise_deg)
    return 180.0 if turned == -180.0 else turned + 0.0  # (-180, 180]; no -0.0


def _mirrored(clockwise_range: list[float] | None) -> list[float] | None:
    if clockwise_range is None:
        return None
    low, high = clockwise_range
    return [_left_positive(high), _left_positive(low)]
