"""HTTP face of the reconstruction service (FastAPI). Run: `pyspatial serve recon`."""

from __future__ import annotations

import io
import json
import logging
from contextlib import asynccontextmanager

import numpy as np
from fastapi import FastAPI, Query, Request
from fastapi.responses import JSONResponse, Response
from pydantic import ValidationError
from starlette.datastructures import UploadFile

from services.recon.backbones import available_backbones
from services.recon.errors import InvalidInput, PayloadTooLarge, ReconServiceError
from services.recon.preview import MAX_PREVIEW_POINTS, point_cloud_preview
from services.recon.scene_store import SceneInput, has_all_intrinsics
from services.recon.service import ReconService
from shared.access import docs_urls, install_access_control
from shared.http_bodies import install_input_error_handlers, read_body_limited
from shared.http_errors import error_responses, install_error_shape
from shared.imaging import decode_base64, media_type
from shared.poses import estimate_up_axis
from shared.reconstruction import Reconstruction
from shared.schemas import (
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
from shared.settings import ReconSettings

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
        yield
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
        return JSONResponse({"detail": error.message}, status_code=error.status_code)

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
        body = Readiness(
            ready=backbone_ready,
            backbone=settings.backbone,
            backbone_ready=backbone_ready,
            backbone_detail=detail,
            cache=cache_mode,
            warnings=warnings,
        )
        return JSONResponse(body.model_dump(), status_code=200 if backbone_ready else 503)

    @app.post(
        "/v1/scenes",
        tags=["scenes"],
        response_model=SceneCreated,
        status_code=201,
        openapi_extra=_UPLOAD_DOC,
        responses={
            200: {"model": SceneCreated, "description": "The same scene had been uploaded before."},
            **error_responses(400, 401, 413, 422, 429),
        },
    )
    async def create_scene(request: Request) -> JSONResponse:
        scene = await _read_scene_upload(request, service)
        scene_id, created = service.add_scene(scene)
        body = SceneCreated(
            scene_id=scene_id,
            num_images=len(scene.images),
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
        return SceneInfo(scene_id=scene_id, **service.store.info(scene_id))

    @app.get(
        "/v1/scenes/{scene_id}/images/{index}",
        tags=["scenes"],
        response_class=Response,
        responses={200: {"content": {"application/octet-stream": {}}}, **error_responses(401, 404, 422, 429)},
    )
    async def scene_image(scene_id: str, index: int) -> Response:
        """One uploaded image file, byte for byte as it was uploaded."""
        return Response(service.store.image_file(scene_id, index), media_type="application/octet-stream")

    @app.post(
        "/v1/scenes/{scene_id}/reconstruct",
        tags=["scenes"],
        response_model=ReconstructionSummary,
        responses=error_responses(401, 404, 422, 429, 503),
    )
    async def reconstruct(scene_id: str, request: ReconstructRequest | None = None) -> ReconstructionSummary:
        outcome = await service.reconstruct(scene_id, request.backbone if request else None)
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
        scene_id: str,
        backbone: str | None = None,
        format: str = Query("npz", pattern="^(npz|ply)$", description="npz (shared.Reconstruction) or ply"),
    ) -> Response:
        recon = (await service.reconstruct(scene_id, backbone)).reconstruction
        if format == "ply":
            return Response(
                recon.to_ply(),
                media_type="application/x-ply",
                headers={"Content-Disposition": f'attachment; filename="{scene_id}.ply"'},
            )
        return Response(recon.to_bytes(), media_type="application/octet-stream")

    @app.get(
        "/v1/scenes/{scene_id}/points",
        tags=["scenes"],
        response_model=PointCloudPreview,
        responses=error_responses(401, 404, 422, 429, 503),
    )
    async def points(
        scene_id: str,
        backbone: str | None = None,
        max_points: int = Query(30_000, ge=1, le=MAX_PREVIEW_POINTS, description="Subsample size."),
    ) -> PointCloudPreview:
        """A subsample of the points with their colours, and the cameras: for viewers."""
        outcome = await service.reconstruct(scene_id, backbone)
        summary = _summary(scene_id, outcome.reconstruction, outcome.cached, outcome.joined_in_flight, {})
        return point_cloud_preview(scene_id, outcome.reconstruction, summary.cameras, summary.up, max_points)

    @app.post(
        "/v1/render",
        tags=["tools"],
        response_class=Response,
        responses={
            200: {"content": {"image/png": {}, "image/jpeg": {}}},
            **error_responses(401, 404, 422, 429, 503),
        },
    )
    async def render(request: RenderRequest) -> Response:
        image = await service.render(
            request.scene_id,
            request.extrinsic,
            request.width,
            request.height,
            request.zoom_out,
            request.format,
            request.backbone,
        )
        return Response(image, media_type=media_type(request.format))

    @app.post(
        "/v1/camera-motion",
        tags=["tools"],
        response_model=CameraMotionResponse,
        responses=error_responses(401, 404, 422, 429, 503),
    )
    async def camera_motion(request: CameraMotionRequest) -> CameraMotionResponse:
        """Per pair of views a description, or (described = false) why there is none."""
        recon, motions, scale = await service.camera_motion(request.scene_id, request.pairs, request.backbone)
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
        cached=cached,
        joined_in_flight=joined,
        timings_ms={k: round(v, 2) for k, v in timings.items()},
    )


# ---- upload parsing ------------------------------------------------------------------------


async def _read_scene_upload(request: Request, service: ReconService) -> SceneInput:
    settings = service.settings
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > settings.max_request_bytes:
        raise PayloadTooLarge(f"request is {declared} bytes; the limit is {settings.max_request_bytes}")
    content_type = request.headers.get("content-type", "")
    if content_type.startswith("multipart/form-data"):
        return await _read_multipart(request, service)
    if content_type.startswith("application/json"):
        body = await read_body_limited(request, settings.max_request_bytes)
        try:
            upload = SceneUpload.model_validate_json(body)
        except ValidationError as error:
            raise InvalidInput(f"invalid scene upload: {_first_error(error)}") from error
        files = [decode_base64(text, f"image {i}") for i, text in enumerate(upload.images)]
        depths = None
        if upload.depths is not None:
            depths = [
                _load_npy(decode_base64(t, f"depth {i}"), f"depth {i}") for i, t in enumerate(upload.depths)
            ]
        return _scene_from_parts(service, files, depths, upload.extrinsics, upload.intrinsics)
    raise InvalidInput(
        "send the images as multipart/form-data (field 'images') or JSON {\"images\": [base64,...]}"
    )


async def _read_multipart(request: Request, service: ReconService) -> SceneInput:
    limit = service.settings.max_images
    try:
        form = await request.form(max_files=2 * limit + 2, max_fields=16)
    except Exception as error:  # starlette raises several parser errors for malformed bodies
        raise InvalidInput(f"could not parse the multipart upload: {error}") from error
    files = []
    for item in form.getlist("images"):
        if not isinstance(item, UploadFile):
            raise InvalidInput("field 'images' must carry files")
        if item.size is not None and item.size > service.settings.max_image_bytes:
            raise PayloadTooLarge(
                f"{item.filename} is {item.size} bytes; the limit is {service.settings.max_image_bytes}"
            )
        files.append(await item.read())
    depths = None
    depth_items = form.getlist("depths")
    if depth_items:
        depths = [
            _load_npy(await item.read(), f"depth {i}")
            for i, item in enumerate(depth_items)
            if isinstance(item, UploadFile)
        ]
    cameras = {}
    for name in ("extrinsics", "intrinsics"):
        raw = form.get(name)
        if raw is not None:
            try:
                cameras[name] = json.loads(raw if isinstance(raw, str) else await raw.read())
            except ValueError as error:
                raise InvalidInput(f"{name} must be JSON: {error}") from error
    return _scene_from_parts(service, files, depths, cameras.get("extrinsics"), cameras.get("intrinsics"))


def _scene_from_parts(
    service: ReconService, files: list[bytes], depths, extrinsics, intrinsics
) -> SceneInput:
    limit = service.settings.max_images
    if not files:
        raise InvalidInput(f"no images: send 1 to {limit} images in the field 'images'")
    if len(files) > limit:
        raise InvalidInput(f"{len(files)} images; a scene has at most {limit}")
    images = [service.decode(blob, f"image {i}") for i, blob in enumerate(files)]
    scene = SceneInput(image_files=files, images=images, depths=depths)
    if isinstance(intrinsics, list):  # null for a view whose camera is unknown
        intrinsics = [np.full((3, 3), np.nan) if matrix is None else matrix for matrix in intrinsics]
    for name, value in (("extrinsics", extrinsics), ("intrinsics", intrinsics)):
        if value is not None:
            try:
                setattr(scene, name, np.asarray(value, dtype=np.float64))
            except (TypeError, ValueError) as error:
                raise InvalidInput(f"{name} must be a list of numeric matrices: {error}") from error
    return scene


def _load_npy(data: bytes, label: str) -> np.ndarray:
    try:
        array = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError) as error:
        raise InvalidInput(f"{label} is not a .npy array: {error}") from error
    if not np.issubdtype(array.dtype, np.number):
        raise InvalidInput(f"{label} must be numeric, got {array.dtype}")
    return array.astype(np.float32)


def _first_error(error: ValidationError) -> str:
    first = error.errors()[0]
    location = ".".join(str(part) for part in first["loc"])
    return f"{location}: {first['msg']}" if location else first["msg"]
