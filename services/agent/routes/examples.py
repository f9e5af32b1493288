"""The bundled examples of the page's gallery (`examples/<name>/example.json` of the checkout).

- `/v1/examples`: every example with its title, description, source (synthetic or real, with the
  citation for real photos), the URLs of its photos and its questions;
- `/v1/examples/{name}/images/{file}`: one photo; `/v1/examples/{name}/thumbnail`: a small JPEG;
- `/v1/example` and `/v1/example/images/{name}`: the demo's example (living_room), as before.

The Docker images leave `examples/` out: there the list is empty and `/v1/example` is a 404.
"""

from __future__ import annotations

import json
import re
from pathlib import Path as FilePath

from fastapi import APIRouter, HTTPException, Path
from fastapi.responses import FileResponse

from shared.wire.errors import error_responses
from shared.wire.schemas import ExampleInfo, ExampleList, ExampleQuestion

EXAMPLES_DIR = FilePath(__file__).resolve().parents[3] / "examples"
DEMO_EXAMPLE = "living_room"
EXAMPLE_NAME = r"^[a-z0-9_]{1,64}$"

router = APIRouter(tags=["web"])


def _spec(name: str) -> dict:
    path = EXAMPLES_DIR / name / "example.json"
    if not re.fullmatch(EXAMPLE_NAME, name) or not path.is_file():
        raise HTTPException(404, f"this installation has no bundled example {name!r} (examples/{name})")
    return json.loads(path.read_text())


def _info(name: str, spec: dict) -> ExampleInfo:
    images = [f"/v1/examples/{name}/images/{file}" for file in spec["images"]]
    questions = [
        ExampleQuestion(
            text=q["text"],
            expected_answer=q.get("expected_answer"),
            expected_words=q.get("expected_words"),
            free_form=q.get("expected_answer") is None,
        )
        for q in spec.get("questions")
        or [{"text": spec["question"], "expected_answer": spec.get("expected_answer")}]
    ]
    return ExampleInfo(
        name=name,
        title=spec.get("title", name),
        description=spec.get("description", ""),
        source=spec.get("source", "synthetic"),
        citation=spec.get("citation"),
        thumbnail=f"/v1/examples/{name}/thumbnail" if "thumbnail" in spec else images[0],
        images=images,
        questions=questions,
    )


@router.get("/v1/examples", response_model=ExampleList, responses=error_responses(401, 429))
async def examples() -> ExampleList:
    """The bundled examples, the demo's first (none when the installation has no examples/)."""
    names = sorted(
        (
            p.parent.name
            for p in EXAMPLES_DIR.glob("*/example.json")
            if re.fullmatch(EXAMPLE_NAME, p.parent.name)
        ),
        key=lambda name: (name != DEMO_EXAMPLE, name),
    )
    return ExampleList(examples=[_info(name, _spec(name)) for name in names])


@router.get(
    "/v1/examples/{name}/images/{file}",
    response_class=FileResponse,
    responses=error_responses(401, 404, 422, 429),  # 422: a name that is no example name
)
async def example_photo(name: str = Path(pattern=EXAMPLE_NAME), file: str = Path()) -> FileResponse:
    if file not in _spec(name)["images"]:
        raise HTTPException(404, f"the example {name!r} has no image {file!r}")
    return FileResponse(EXAMPLES_DIR / name / file)


@router.get(
    "/v1/examples/{name}/thumbnail",
    response_class=FileResponse,
    responses=error_responses(401, 404, 422, 429),  # 422: a name that is no example name
)
async def example_thumbnail(name: str = Path(pattern=EXAMPLE_NAME)) -> FileResponse:
    """A small JPEG of the example's first photo, for the gallery."""
    spec = _spec(name)
    if "thumbnail" not in spec:
        raise HTTPException(404, f"the example {name!r} has no thumbnail")
    return FileResponse(EXAMPLES_DIR / name / spec["thumbnail"], media_type="image/jpeg")


@router.get("/v1/example", responses=error_responses(401, 404, 429))
async def example() -> dict:
    """The demo's example: its question and the URLs of its images."""
    spec = _spec(DEMO_EXAMPLE)
    return {
        "question": spec["question"],
        "expected_answer": spec.get("expected_answer"),
        "images": [f"/v1/example/images/{name}" for name in spec["images"]],
    }


@router.get(
    "/v1/example/images/{name}",
    response_class=FileResponse,
    responses=error_responses(401, 404, 429),
)
async def example_image(name: str) -> FileResponse:
    if name not in _spec(DEMO_EXAMPLE)["images"]:
        raise HTTPException(404, f"the example has no image {name!r}")
    return FileResponse(EXAMPLES_DIR / DEMO_EXAMPLE / name)
