"""`POST /v1/route`: a route plan from a start view to a goal, for a robot of a given size.

Multipart like `/v1/solve`: files `images` (and optional `depths`, `.npy` z-depth in metres, with
JSON text fields `extrinsics` and `intrinsics`, the posed RGB-D upload's format) or a `scene_id`;
text fields `start_view` (1-based), `goal` and `robot` (JSON). JSON bodies are `RouteRequest`.
The work is in services/agent/route_plan.py.
"""

from __future__ import annotations

import io

import anyio
import numpy as np
import pydantic_core
from fastapi import APIRouter, Request
from pydantic import ValidationError
from starlette.datastructures import UploadFile

from services.agent import route_plan
from services.agent.errors import SolveError
from services.agent.routes.dependencies import SettingsDep, TenantReconDep
from shared.imaging.codecs import decode_base64
from shared.wire.bodies import read_body_limited
from shared.wire.errors import error_responses, first_validation_message
from shared.wire.schemas import RouteRequest, RouteResponse
from shared.wire.settings import AgentSettings

_JSON_FIELDS = {"goal", "robot", "extrinsics", "intrinsics"}
_FILES = ("images", "depths")
_ROUTE_DOC = {
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {"schema": RouteRequest.model_json_schema()},
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "properties": {
                        "images": {"type": "array", "items": {"type": "string", "format": "binary"}},
                        "depths": {"type": "array", "items": {"type": "string", "format": "binary"}},
                        "extrinsics": {
                            "type": "string",
                            "description": "JSON: per view 3x4 camera-from-world",
                        },
                        "intrinsics": {"type": "string", "description": "JSON: per view 3x3"},
                        "scene_id": {"type": "string"},
                        "backbone": {"type": "string"},
                        "start_view": {"type": "integer"},
                        "goal": {"type": "string", "description": "JSON RouteGoal"},
                        "robot": {"type": "string", "description": "JSON RobotSpec"},
                    },
                    "required": ["goal"],
                }
            },
        },
    }
}

router = APIRouter(tags=["route"])


@router.post(
    "/v1/route",
    response_model=RouteResponse,
    openapi_extra=_ROUTE_DOC,
    responses=error_responses(400, 401, 404, 409, 413, 422, 429, 502, 503, 504),
)
async def plan_a_route(request: Request, recon: TenantReconDep, settings: SettingsDep) -> RouteResponse:
    """Plan turns and forward moves from the floor below the start view to the goal (left-positive turns)."""
    body, images, depths = await _read_route_request(request, settings)
    return await anyio.to_thread.run_sync(
        route_plan.route, body, images, depths, recon, settings.route_unseen_cost
    )


async def _read_route_request(request: Request, settings: AgentSettings) -> tuple[RouteRequest, list, list]:
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > settings.max_request_bytes:
        raise SolveError(413, f"request is {declared} bytes; the limit is {settings.max_request_bytes}")
    content_type = request.headers.get("content-type", "")
    try:
        if content_type.startswith("application/json"):
            body = RouteRequest.model_validate_json(
                await read_body_limited(request, settings.max_request_bytes)
            )
            images = [decode_base64(text, f"image {i + 1}") for i, text in enumerate(body.images or [])]
            return body.model_copy(update={"images": None}), images, []
        if content_type.startswith("multipart/form-data"):
            return await _read_multipart(request, settings)
    except ValidationError as error:
        raise SolveError(422, first_validation_message(error.errors())) from error
    raise SolveError(422, "send JSON {goal, images|scene_id} or multipart/form-data with 'images' files")


async def _read_multipart(request: Request, settings: AgentSettings) -> tuple[RouteRequest, list, list]:
    try:
        form = await request.form(max_files=2 * settings.max_images + 1, max_fields=16)
    except Exception as error:  # starlette raises several parser errors for malformed bodies
        raise SolveError(422, f"could not parse the multipart request: {error}") from error
    files: dict[str, list[bytes]] = {name: [] for name in _FILES}
    for name in _FILES:
        for item in form.getlist(name):
            if not isinstance(item, UploadFile):
                raise SolveError(422, f"field {name!r} must carry files")
            if item.size is not None and item.size > settings.max_image_bytes:
                raise SolveError(
                    413, f"{item.filename} is {item.size} bytes; the limit is {settings.max_image_bytes}"
                )
            files[name].append(await item.read())
    body = RouteRequest.model_validate(_text_fields(form))
    return body, files["images"], [_depth(blob, i) for i, blob in enumerate(files["depths"])]


def _depth(blob: bytes, index: int) -> np.ndarray:
    try:
        depth = np.load(io.BytesIO(blob), allow_pickle=False)
    except (ValueError, OSError) as error:
        raise SolveError(422, f"depth {index + 1} is not a .npy array: {error}") from error
    if depth.ndim != 2 or depth.dtype.kind != "f":
        raise SolveError(422, f"depth {index + 1} must be a 2-D float array, got {depth.dtype} {depth.shape}")
    return depth


def _text_fields(form) -> dict:
    fields = {}
    for name, value in form.multi_items():
        if name in _FILES or value == "":
            continue
        if not isinstance(value, str):
            raise SolveError(422, f"field {name!r} must be text, not a file")
        if name in fields:
            raise SolveError(422, f"field {name!r} is given more than once")
        fields[name] = value
    for name in _JSON_FIELDS & fields.keys():
        try:
            fields[name] = pydantic_core.from_json(fields[name])
        except ValueError as error:
            raise SolveError(422, f"field {name!r} must be JSON: {error}") from error
    return fields


__all__ = ["router"]
