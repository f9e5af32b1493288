"""The web page (`/`) and the reads it needs besides /v1/solve (its static files are mounted at `/web`;
the examples of its gallery are in examples.py).

- `/v1/scenes/{scene_id}/points`: a subsample of the reconstruction for the 3D view, read from
  the recon service (the page talks to the agent only, so one origin serves everything);
- `/v1/scenes/{scene_id}/reconstruction?format=ply|glb`: the reconstruction's points as a file,
  streamed from recon as it arrives (PLY is streamed by recon too);
- `/v1/backbones`: the recon service's backbones, for the page's menu.
"""

from __future__ import annotations

from contextlib import ExitStack

import anyio
from fastapi import APIRouter, Path, Query, Request
from fastapi.responses import Response, StreamingResponse

from services.agent.routes.dependencies import TenantReconDep
from shared.wire.errors import error_responses
from shared.wire.schemas import SCENE_ID_PATTERN, PointCloudPreview

router = APIRouter()


@router.get("/", include_in_schema=False)
async def page(request: Request) -> Response:
    """index.html with Subresource Integrity (services/agent/web_page.py); headers by SecurityHeaders."""
    return Response(request.app.state.web_page.html, media_type="text/html")


@router.get(
    "/v1/scenes/{scene_id}/points",
    tags=["scenes"],
    response_model=PointCloudPreview,
    responses=error_responses(401, 404, 409, 422, 429, 502, 503, 504),
)
async def points(
    recon: TenantReconDep,
    scene_id: str = Path(pattern=SCENE_ID_PATTERN),  # checked before it goes into a recon URL
    backbone: str | None = None,
    max_points: int = Query(30_000, ge=1, le=200_000),
) -> PointCloudPreview:
    """A subsample of the scene's points and its cameras (from the recon service), for viewers."""
    return await anyio.to_thread.run_sync(recon.points, scene_id, backbone, max_points)


@router.get("/v1/backbones", tags=["web"], responses=error_responses(401, 429, 502, 503, 504))
async def backbones(recon: TenantReconDep) -> dict:
    """The recon service's backbones: each with availability (and why not), units and device; the
    default, what `auto` stands for now, and the names a request may use (for the page's menu)."""
    return await anyio.to_thread.run_sync(recon.backbones)


@router.get(
    "/v1/scenes/{scene_id}/reconstruction",
    tags=["scenes"],
    response_class=StreamingResponse,
    responses={
        200: {"content": {"application/x-ply": {}, "model/gltf-binary": {}}},
        **error_responses(401, 404, 422, 429, 502, 503, 504),
    },
)
async def reconstruction_file(
    recon: TenantReconDep,
    scene_id: str = Path(pattern=SCENE_ID_PATTERN),
    backbone: str | None = None,
    format: str = Query("ply", pattern="^(ply|glb)$", description="ply (binary) or glb (binary glTF)"),
) -> StreamingResponse:
    """The reconstruction's coloured points as a PLY or GLB file, streamed from the recon service."""
    stream = ExitStack()  # recon's response stays open while its bytes are passed on
    export = recon.export(scene_id, format, backbone)
    upstream = await anyio.to_thread.run_sync(stream.enter_context, export)  # errors map before any byte

    def chunks():
        with stream:
            yield from upstream.iter_bytes()

    headers = {"Content-Disposition": f'attachment; filename="{scene_id}.{format}"'}
    if "content-length" in upstream.headers:
        headers["Content-Length"] = upstream.headers["content-length"]
    return StreamingResponse(chunks(), media_type=upstream.headers.get("content-type"), headers=headers)
