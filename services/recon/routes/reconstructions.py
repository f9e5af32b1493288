"""A scene's reconstruction: reconstruct it (the summary), download it (npz, PLY streamed, GLB), or read a
subsample of its points for a viewer. All three share one cached, single-flight job per scene and
backbone (services/recon/service.py); a client that disconnects cancels only its own wait."""

from __future__ import annotations

from fastapi import APIRouter, Query, Request
from fastapi.responses import Response, StreamingResponse

from services.recon.disconnect import until_disconnected
from services.recon.exports import GLB_MEDIA_TYPE, PLY_MEDIA_TYPE, to_glb
from services.recon.offload import run_cpu
from services.recon.preview import MAX_PREVIEW_POINTS, point_cloud_preview
from services.recon.routes.dependencies import ServiceDep, TenantDep
from services.recon.summary import camera_infos, reconstruction_summary, scene_up
from shared.wire.errors import error_responses
from shared.wire.schemas import PointCloudPreview, ReconstructionSummary, ReconstructRequest

router = APIRouter(tags=["scenes"])


@router.post(
    "/v1/scenes/{scene_id}/reconstruct",
    response_model=ReconstructionSummary,
    responses=error_responses(401, 404, 409, 422, 429, 503),
)
async def reconstruct(
    http: Request,
    scene_id: str,
    service: ServiceDep,
    tenant: TenantDep,
    request: ReconstructRequest | None = None,
) -> ReconstructionSummary:
    outcome = await until_disconnected(
        http, service.reconstruct(scene_id, request.backbone if request else None, tenant)
    )
    return reconstruction_summary(
        scene_id, outcome.reconstruction, outcome.cached, outcome.joined_in_flight, outcome.timings_ms
    )


@router.get(
    "/v1/scenes/{scene_id}/reconstruction",
    responses={
        200: {"content": {"application/octet-stream": {}, PLY_MEDIA_TYPE: {}, GLB_MEDIA_TYPE: {}}},
        **error_responses(401, 404, 409, 422, 429, 503),
    },
)
async def reconstruction(
    http: Request,
    scene_id: str,
    service: ServiceDep,
    tenant: TenantDep,
    backbone: str | None = None,
    format: str = Query(
        "npz",
        pattern="^(npz|ply|glb)$",
        description="npz (shared.Reconstruction), ply (binary, streamed as written) or glb (binary glTF)",
    ),
) -> Response:
    recon = (await until_disconnected(http, service.reconstruct(scene_id, backbone, tenant))).reconstruction
    attachment = {"Content-Disposition": f'attachment; filename="{scene_id}.{format}"'}
    if format == "ply":
        headers = {**attachment, "Content-Length": str(recon.ply_size())}
        return StreamingResponse(recon.ply_chunks(), media_type=PLY_MEDIA_TYPE, headers=headers)
    if format == "glb":
        return Response(await run_cpu(to_glb, recon), media_type=GLB_MEDIA_TYPE, headers=attachment)
    return Response(await run_cpu(recon.to_bytes), media_type="application/octet-stream")


@router.get(
    "/v1/scenes/{scene_id}/points",
    response_model=PointCloudPreview,
    responses=error_responses(401, 404, 409, 422, 429, 503),
)
async def points(
    http: Request,
    scene_id: str,
    service: ServiceDep,
    tenant: TenantDep,
    backbone: str | None = None,
    max_points: int = Query(30_000, ge=1, le=MAX_PREVIEW_POINTS, description="Subsample size."),
) -> PointCloudPreview:
    """A subsample of the points with their colours, and the cameras: for viewers."""
    recon = (await until_disconnected(http, service.reconstruct(scene_id, backbone, tenant))).reconstruction
    cameras, up = camera_infos(recon), scene_up(recon).tolist()
    return await run_cpu(point_cloud_preview, scene_id, recon, cameras, up, max_points)
