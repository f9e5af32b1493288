"""`POST /v1/render`: the scene's points seen from a pose (3x4 camera-from-world, OpenCV axes)."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import Response

from services.recon.disconnect import until_disconnected
from services.recon.routes.dependencies import ServiceDep, TenantDep
from shared.imaging.codecs import media_type
from shared.wire.errors import error_responses
from shared.wire.schemas import RenderRequest

router = APIRouter(tags=["tools"])
RENDER_WARNING_HEADER = "X-Pyspatial-Warning"


@router.post(
    "/v1/render",
    response_class=Response,
    responses={
        200: {
            "content": {"image/png": {}, "image/jpeg": {}},
            "headers": {
                RENDER_WARNING_HEADER: {
                    "description": "Set when the focal length is unknown and the views cannot fix it: "
                    "the render uses the central focal hypothesis, and says so.",
                    "schema": {"type": "string"},
                }
            },
        },
        **error_responses(401, 404, 409, 422, 429, 503),
    },
)
async def render(http: Request, request: RenderRequest, service: ServiceDep, tenant: TenantDep) -> Response:
    image = await until_disconnected(
        http,
        service.render(
            request.scene_id,
            request.extrinsic,
            request.width,
            request.height,
            request.zoom_out,
            request.format,
            request.backbone,
            tenant,
        ),
    )
    warning = await service.render_warning(request.scene_id, request.backbone, tenant)
    headers = {RENDER_WARNING_HEADER: warning} if warning else None
    return Response(image, media_type=media_type(request.format), headers=headers)
