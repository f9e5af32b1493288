"""Scenes: upload (content-addressed, so the same upload twice is one scene), read back its info
and its image files. Parsing and limits live in `services/recon/uploads.py`."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse, Response

from services.recon.offload import run_cpu
from services.recon.routes.dependencies import ServiceDep, TenantDep, UploadsDep
from services.recon.scene_store import has_all_intrinsics
from services.recon.uploads import UPLOAD_OPENAPI
from shared.wire.errors import error_responses
from shared.wire.schemas import SceneCreated, SceneInfo

router = APIRouter(tags=["scenes"])


@router.post(
    "/v1/scenes",
    response_model=SceneCreated,
    status_code=201,
    openapi_extra=UPLOAD_OPENAPI,
    responses={
        200: {"model": SceneCreated, "description": "The same scene had been uploaded before."},
        **error_responses(400, 401, 413, 422, 429, 503, 507),
    },
)
async def create_scene(
    request: Request, service: ServiceDep, uploads: UploadsDep, tenant: TenantDep
) -> JSONResponse:
    scene = await uploads.read(request)
    scene_id, created = await service.add_scene(scene, tenant)
    body = SceneCreated(
        scene_id=scene_id,
        num_images=scene.num_images,
        image_sizes=scene.image_sizes,
        has_depth=scene.depths is not None,
        has_cameras=scene.extrinsics is not None and has_all_intrinsics(scene),
        kind=scene.kind,
        created=created,
    )
    return JSONResponse(body.model_dump(), status_code=201 if created else 200)


@router.get("/v1/scenes/{scene_id}", response_model=SceneInfo, responses=error_responses(401, 404, 429))
async def scene_info(scene_id: str, service: ServiceDep, tenant: TenantDep) -> SceneInfo:
    return SceneInfo(scene_id=scene_id, **await run_cpu(service.store.info, scene_id, tenant))


@router.get(
    "/v1/scenes/{scene_id}/images/{index}",
    response_class=Response,
    responses={200: {"content": {"application/octet-stream": {}}}, **error_responses(401, 404, 422, 429)},
)
async def scene_image(scene_id: str, index: int, service: ServiceDep, tenant: TenantDep) -> Response:
    """One uploaded image file, byte for byte as it was uploaded."""
    blob = await run_cpu(service.store.image_file, scene_id, index, tenant)
    return Response(blob, media_type="application/octet-stream")
