"""HTTP face of the reconstruction service (FastAPI). Run: `pyspatial serve recon`."""

from __future__ import annotations

import logging
import math
from contextlib import asynccontextmanager
from dataclasses import asdict

import numpy as np
from fastapi import FastAPI, Query, Request
from fastapi.responses import JSONResponse, Response

from services.recon.backbones import available_backbones
from services.recon.disconnect import until_disconnected
from services.recon.errors import ReconServiceError
from services.recon.offload import run_cpu
from services.recon.preview import MAX_PREVIEW_POINTS, point_cloud_preview
from services.recon.scene_store import has_all_intrinsics
from services.recon.service import ReconService
from services.recon.uploads import SceneUploads
from shared.geometry.poses import estimate_up_axis
from shared.geometry.reconstruction import Reconstruction
from shared.imaging.codecs import media_type
from shared.wire.access import docs_urls, install_access_control
from shared.wire.bodies import install_input_error_handlers
from shared.wire.errors import error_responses, install_error_shape
from shared.wire.schemas import (
    CameraInfo,
    CameraMotionItem,
    CameraMotionRequest,
    CameraMotionResponse,
    PointCloudPreview,
    Readiness,
    ReconstructionSummary,
    ReconstructRequest,
    RenderRequest,
    SceneCreated,
    SceneInfo,
    SceneUpload,
)
from shared.wire.settings import ReconSettings

log = logging.getLogger("pyspatial.recon")

_UPLOAD_DOC = {
    "requestBody": {
        "required": True,
        "content": {
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "properties": {
                        "images": {"type": "array", "items": {"type": "string", "format": "binary"}},
                        "depths": {
                            "type": "array",
                            "items": {"type": "string", "format": "binary"},
                            "description": "optional float32 .npy z-depth per image",
                        },
                        "extrinsics": {"type": "string", "description": "optional JSON list of 3x4"},
                        "intrinsics": {
                            "type": "string",
                            "description": "optional JSON list of 3x3 (upright image pixels), null per "
                            "view for unknown cameras",
                        },
                    },
                    "required": ["images"],
                }
            },
            "application/json": {"schema": SceneUpload.model_json_schema()},
        },
    }
}


def create_app(settings: ReconSettings | None = None) -> FastAPI:
    settings = settings or ReconSettings()
    service = ReconService(settings)
    uploads = SceneUploads(settings)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        ready, detail = service.backbone_status()
        log.warning(
            "recon service: backbone=%s (%s), cache=%s, data=%s",
            settings.backbone,
            detail,
            await service.cache.check(),
            settings.data_dir,
        )
        if not ready:  # no silent fallback: the service answers, /readyz says 503 and why
            log.error("backbone %s is NOT ready: %s", settings.backbone, detail)
        storage = service.store.check_writable()
        if storage:
            log.error("data dir is NOT writable: %s", storage)
        yield
        uploads.close()
        # SIGTERM: uvicorn stops accepting and gives requests `drain_s` (--timeout-graceful-shutdown);
        # then queued reconstructions are dropped and running ones stopped, releasing their leases
        # for another replica (the reconstruction threads are daemons: they do not delay the exit).
        await service.jobs.drain(timeout_s=1.0)
        await service.cache.close()

    app = FastAPI(
        title="pySpatial reconstruction service",
        version="0.1.0",
        description="Reconstructs scenes from images and renders, measures and describes them.",
        lifespan=lifespan,
        redirect_slashes=False,  # "/v1/scenes/<id>%2F" must be a 404, not a redirect elsewhere
        **docs_urls(settings),
    )
    app.state.service = service
    install_error_shape(app)
    install_access_control(app, settings)

    @app.exception_handler(ReconServiceError)
    async def service_error(_: Request, error: ReconServiceError) -> JSONResponse:
        headers = {"Retry-After": str(error.retry_after_s)} if error.retry_after_s else None
        return JSONResponse({"detail": error.message}, status_code=error.status_code, headers=headers)

    install_input_error_handlers(app)

    @app.get("/v1/backbones", tags=["health"], responses=error_responses(401, 429))
    async def backbones() -> dict:
        """The registered backbones and the default one."""
        return {"default": settings.backbone, "available": available_backbones()}

    @app.get("/healthz", tags=["health"])
    async def healthz() -> dict:
        return {"status": "ok"}

    @app.get(
        "/readyz",
        tags=["health"],
        response_model=Readiness,
        responses={503: {"model": Readiness, "description": "Not ready; `backbone_detail` says why."}},
    )
    async def readyz() -> JSONResponse:
        backbone_ready, detail = service.backbone_status()
        cache_mode = await service.cache.check()
        warnings = []
        if cache_mode == "redis-unavailable":
            warnings.append(
                "Redis is unreachable: serving from the in-process cache "
                f"({service.cache.pending_writes} writes pending)"
            )
        storage = await run_cpu(service.storage_status)
        warnings.extend(storage.warnings)
        ready = backbone_ready and storage.ok
        body = Readiness(
            ready=ready,
            backbone=settings.backbone,
            backbone_ready=backbone_ready,
            backbone_detail=detail,
            cache=cache_mode,
            storage=storage.detail,
            warnings=warnings,
        )
        return JSONResponse(body.model_dump(), status_code=200 if ready else 503)

    @app.post(
        "/v1/scenes",
        tags=["scenes"],
        response_model=SceneCreated,
        status_code=201,
        openapi_extra=_UPLOAD_DOC,
        responses={
            200: {"model": SceneCreated, "description": "The same scene had been uploaded before."},
            **error_responses(400, 401, 413, 422, 429, 503, 507),
        },
    )
    async def create_scene(request: Request) -> JSONResponse:
        scene = await uploads.read(request)
        scene_id, created = await service.add_scene(scene)
        body = SceneCreated(
            scene_id=scene_id,
            num_images=scene.num_images,
            image_sizes=scene.image_sizes,
            has_depth=scene.depths is not None,
            has_cameras=scene.extrinsics is not None and has_all_intrinsics(scene),
            created=created,
        )
        return JSONResponse(body.model_dump(), status_code=201 if created else 200)

    @app.get(
        "/v1/scenes/{scene_id}",
        tags=["scenes"],
        response_model=SceneInfo,
        responses=error_responses(401, 404, 429),
    )
    async def scene_info(scene_id: str) -> SceneInfo:
        return SceneInfo(scene_id=scene_id, **await run_cpu(service.store.info, scene_id))

    @app.get(
        "/v1/scenes/{scene_id}/images/{index}",
        tags=["scenes"],
        response_class=Response,
        responses={200: {"content": {"application/octet-stream": {}}}, **error_responses(401, 404, 422, 429)},
    )
    async def scene_image(scene_id: str, index: int) -> Response:
        """One uploaded image file, byte for byte as it was uploaded."""
        blob = await run_cpu(service.store.image_file, scene_id, index)
        return Response(blob, media_type="application/octet-stream")

    @app.post(
        "/v1/scenes/{scene_id}/reconstruct",
        tags=["scenes"],
        response_model=ReconstructionSummary,
        responses=error_responses(401, 404, 422, 429, 503),
    )
    async def reconstruct(
        http: Request, scene_id: str, request: ReconstructRequest | None = None
    ) -> ReconstructionSummary:
        outcome = await until_disconnected(
            http, service.reconstruct(scene_id, request.backbone if request else None)
        )
        return _summary(
            scene_id, outcome.reconstruction, outcome.cached, outcome.joined_in_flight, outcome.timings_ms
        )

    @app.get(
        "/v1/scenes/{scene_id}/reconstruction",
        tags=["scenes"],
        responses={
            200: {"content": {"application/octet-stream": {}, "application/x-ply": {}}},
            **error_responses(401, 404, 422, 429, 503),
        },
    )
    async def reconstruction(
        http: Request,
        scene_id: str,
        backbone: str | None = None,
        format: str = Query("npz", pattern="^(npz|ply)$", description="npz (shared.Reconstruction) or ply"),
    ) -> Response:
        recon = (await until_disconnected(http, service.reconstruct(scene_id, backbone))).reconstruction
        if format == "ply":
            return Response(
                await run_cpu(recon.to_ply),
                media_type="application/x-ply",
                headers={"Content-Disposition": f'attachment; filename="{scene_id}.ply"'},
            )
        return Response(await run_cpu(recon.to_bytes), media_type="application/octet-stream")

    @app.get(
        "/v1/scenes/{scene_id}/points",
        tags=["scenes"],
        response_model=PointCloudPreview,
        responses=error_responses(401, 404, 422, 429, 503),
    )
    async def points(
        http: Request,
        scene_id: str,
        backbone: str | None = None,
        max_points: int = Query(30_000, ge=1, le=MAX_PREVIEW_POINTS, description="Subsample size."),
    ) -> PointCloudPreview:
        """A subsample of the points with their colours, and the cameras: for viewers."""
        outcome = await until_disconnected(http, service.reconstruct(scene_id, backbone))
        summary = _summary(scene_id, outcome.reconstruction, outcome.cached, outcome.joined_in_flight, {})
        return await run_cpu(
            point_cloud_preview, scene_id, outcome.reconstruction, summary.cameras, summary.up, max_points
        )

    @app.post(
        "/v1/render",
        tags=["tools"],
        response_class=Response,
        responses={
            200: {"content": {"image/png": {}, "image/jpeg": {}}},
            **error_responses(401, 404, 422, 429, 503),
        },
    )
    async def render(http: Request, request: RenderRequest) -> Response:
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
            ),
        )
        return Response(image, media_type=media_type(request.format))

    @app.post(
        "/v1/camera-motion",
        tags=["tools"],
        response_model=CameraMotionResponse,
        responses=error_responses(401, 404, 422, 429, 503),
    )
    async def camera_motion(http: Request, request: CameraMotionRequest) -> CameraMotionResponse:
        """Per pair of views a description, or (described = false) why there is none."""
        recon, motions, scale = await until_disconnected(
            http, service.camera_motion(request.scene_id, request.pairs, request.backbone)
        )
        items = [CameraMotionItem.model_validate(m.to_dict()) for m in motions]
        return CameraMotionResponse(
            scene_id=request.scene_id,
            backbone=recon.backbone,
            motions=items,
            text="\n".join(item.sentence for item in items),
            scene_scale=scale,
            warnings=recon.warnings,
        )

    return app


def _finite_only(values: dict) -> dict:
    """NaN (not measured) becomes null: JSON has no NaN."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in values.items()}


def _summary(
    scene_id: str, recon: Reconstruction, cached: bool, joined: bool, timings: dict[str, float]
) -> ReconstructionSummary:
    sources = recon.intrinsics_source or [None] * recon.num_views
    cameras = [
        CameraInfo(
            index=i,
            extrinsic=recon.extrinsics[i].tolist() if recon.registered[i] else None,
            intrinsic=recon.intrinsics[i].tolist() if np.all(np.isfinite(recon.intrinsics[i])) else None,
            intrinsics_source=sources[i],
            width=int(recon.image_sizes[i][0]),
            height=int(recon.image_sizes[i][1]),
            registered=bool(recon.registered[i]),
            confidence=_finite_only(asdict(recon.view_confidence[i])),
        )
        for i in range(recon.num_views)
    ]
    low, high = recon.bounds()
    registered = recon.extrinsics[recon.registered]
    up = estimate_up_axis(registered) if len(registered) else np.array([0.0, -1.0, 0.0])
    return ReconstructionSummary(
        scene_id=scene_id,
        backbone=recon.backbone,
        backbone_version=recon.backbone_version,
        cameras=cameras,
        num_points=recon.num_points,
        bounds_min=low.tolist(),
        bounds_max=high.tolist(),
        up=up.tolist(),
        warnings=recon.warnings,
        pairs=[_finite_only(asdict(pair)) for pair in recon.pair_confidence],
        cached=cached,
        joined_in_flight=joined,
        timings_ms={k: round(v, 2) for k, v in timings.items()},
    )
