"""The web page (`/`) and the reads it needs besides /v1/solve (its static files are mounted at `/web`).

- `/v1/scenes/{scene_id}/points`: a subsample of the reconstruction for the 3D view, read from
  the recon service (the page talks to the agent only, so one origin serves everything);
- `/v1/backbones`: the recon service's backbones, for the page's menu;
- `/v1/example`: the bundled example (question + images) when the checkout has it.
"""

from __future__ import annotations

import json
from pathlib import Path as FilePath

import anyio
from fastapi import APIRouter, HTTPException, Path, Query
from fastapi.responses import FileResponse

from services.agent.routes.dependencies import PipelineDep
from shared.wire.errors import error_responses
from shared.wire.schemas import SCENE_ID_PATTERN, PointCloudPreview

WEB_DIR = FilePath(__file__).resolve().parents[1] / "web"
EXAMPLE_DIR = FilePath(__file__).resolve().parents[3] / "examples" / "living_room"

router = APIRouter()


@router.get("/", include_in_schema=False)
async def page() -> FileResponse:
    return FileResponse(WEB_DIR / "index.html", headers={"Cache-Control": "no-cache"})


@router.get(
    "/v1/scenes/{scene_id}/points",
    tags=["scenes"],
    response_model=PointCloudPreview,
    responses=error_responses(401, 404, 409, 422, 429, 502, 503, 504),
)
async def points(
    pipeline: PipelineDep,
    scene_id: str = Path(pattern=SCENE_ID_PATTERN),  # checked before it goes into a recon URL
    backbone: str | None = None,
    max_points: int = Query(30_000, ge=1, le=200_000),
) -> PointCloudPreview:
    """A subsample of the scene's points and its cameras (from the recon service), for viewers."""
    return await anyio.to_thread.run_sync(pipeline.recon.points, scene_id, backbone, max_points)


@router.get("/v1/backbones", tags=["web"], responses=error_responses(401, 429, 502, 503, 504))
async def backbones(pipeline: PipelineDep) -> dict:
    """The recon service's backbones: each with availability (and why not), units and device; the
    default, what `auto` stands for now, and the names a request may use (for the page's menu)."""
    return await anyio.to_thread.run_sync(pipeline.recon.backbones)


@router.get("/v1/example", tags=["web"], responses=error_responses(401, 404, 429))
async def example() -> dict:
    """The bundled example: its question and the URLs of its images."""
    spec = _example_spec()
    return {
        "question": spec["question"],
        "expected_answer": spec.get("expected_answer"),
        "images": [f"/v1/example/images/{name}" for name in spec["images"]],
    }


@router.get(
    "/v1/example/images/{name}",
    tags=["web"],
    response_class=FileResponse,
    responses=error_responses(401, 404, 429),
)
async def example_image(name: str) -> FileResponse:
    if name not in _example_spec()["images"]:
        raise HTTPException(404, f"the example has no image {name!r}")
    return FileResponse(EXAMPLE_DIR / name)


def _example_spec() -> dict:
    path = EXAMPLE_DIR / "example.json"
    if not path.is_file():
        raise HTTPException(404, "this installation has no bundled example (examples/living_room)")
    return json.loads(path.read_text())
