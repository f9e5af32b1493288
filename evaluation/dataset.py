"""Read benchmark questions from JSONL: MindCube's schema, and Omni3D-Bench's (one image per item).

MindCube lines carry ``id, category, type, meta_info`` (always a list), ``question, images,
gt_answer``; the JSONL lives in ``data/raw/`` and image paths are relative to the data root
``data/`` ("other_all_image/among/shoe_216/front_007.jpg"). As MindCube's own loader does, an item
whose image is missing is skipped with a warning (never the end of the run), and an absolute path
containing ``other_all_image/`` is remapped under the data root. The setting is the id's prefix
(``among_``, ``around``/``aroundnew_``, ``rotation_``, ``translation_``).

Omni3D-Bench lines carry ``question, answer, answer_type`` and one image; their ids and field names
vary between exports, so a few spellings are accepted.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from shared.questions.intent import QuestionIntent, parse_question, setting_from_id

MINDCUBE_SETTINGS = ("rotation", "among", "around")
UNKNOWN_SETTING = "other"
IMAGE_FOLDER = "other_all_image/"  # MindCube's image folder under the data root

log = logging.getLogger("pyspatial.evaluation")


class DatasetError(ValueError):
    """A JSONL line is not a usable benchmark item (the message names the file and line)."""


@dataclass
class BenchmarkItem:
    id: str
    question: str
    gt_answer: str
    images: list[Path]
    setting: str = UNKNOWN_SETTING  # MindCube: rotation / among / around
    answer_type: str | None = None  # Omni3D-Bench: int / float / str
    category: Any = None
    type: str | None = None
    meta_info: Any = field(default_factory=list)  # MindCube: a list; kept as the data has it
    exact_scene: dict[str, Any] | None = None  # synthetic items: {"scene_file", "view_indices"}

    @cached_property
    def intent(self) -> QuestionIntent:
        """The question parsed once (its options, family, views), as the agent parses it."""
        return parse_question(self.question, len(self.images) or None, self.id)


def setting_of(item_id: str, image_paths: list[str], category: Any = None) -> str:
    """The MindCube setting, read from the id prefix ("among_0012_...", "aroundnew_..."), else from
    the image paths. MindCube names its ids and image folders after the setting; the category list
    is the last resort."""
    from_id = setting_from_id(item_id)
    if from_id is not None and from_id != "unknown":
        return from_id
    candidates = [item_id.lower(), *(p.lower() for p in image_paths)]
    for text in candidates:
        for setting in MINDCUBE_SETTINGS:
            if text.startswith(setting):
                return setting
    for text in candidates[1:]:
        for setting in MINDCUBE_SETTINGS:
            if f"/{setting}/" in f"/{text}" or f"/{setting}_" in f"/{text}":
                return setting
    categories = category if isinstance(category, list) else [category]
    for value in categories:
        if isinstance(value, str) and value.lower() in MINDCUBE_SETTINGS:
            return value.lower()
    return UNKNOWN_SETTING


def _read_lines(jsonl: Path) -> list[tuple[int, dict[str, Any]]]:
    records = []
    with Path(jsonl).open(encoding="utf-8") as handle:
        for number, line in enumerate(handle, start=1):
            if not line.strip():
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError as error:
                raise DatasetError(f"{jsonl}:{number}: not JSON ({error.msg})") from error
            if not isinstance(record, dict):
                raise DatasetError(f"{jsonl}:{number}: expected a JSON object")
            records.append((number, record))
    return records


def _require(record: dict[str, Any], names: tuple[str, ...], where: str) -> Any:
    for name in names:
        if record.get(name) is not None:
            return record[name]
    raise DatasetError(f"{where}: missing field {' / '.join(names)}")


def _resolve_images(paths: list[str], image_root: Path, where: str) -> list[Path]:
    resolved = [Path(image_root) / p for p in paths]
    missing = [str(p) for p in resolved if not p.is_file()]
    if missing:
        raise DatasetError(f"{where}: image not found: {missing[0]} (is --image-root right?)")
    return resolved


def default_image_root(jsonl: Path) -> Path:
    """MindCube's layout: the JSONL in ``data/raw/``, images relative to ``data/``."""
    parent = Path(jsonl).resolve().parent
    return parent.parent if parent.name == "raw" else parent


def _mindcube_image(path: str, image_root: Path) -> Path:
    """The image's file: relative paths under the data root; an absolute path from another machine
    that contains ``other_all_image/`` is remapped there too."""
    if Path(path).is_absolute() and IMAGE_FOLDER in path:
        return Path(image_root) / path[path.index(IMAGE_FOLDER) :]
    return Path(image_root) / path


def _exact_scene(record: dict[str, Any]) -> dict[str, Any] | None:
    """Exact cameras and depth of a synthetic item: ``pyspatial_scene``, or an older dict meta_info."""
    scene = record.get("pyspatial_scene")
    if scene is None and isinstance(record.get("meta_info"), dict):
        scene = record["meta_info"]
    if isinstance(scene, dict) and scene.get("scene_file") and scene.get("view_indices") is not None:
        return {"scene_file": scene["scene_file"], "view_indices": list(scene["view_indices"])}
    return None


def read_mindcube(
    jsonl: Path, image_root: Path | None = None, limit: int | None = None, skipped: list[str] | None = None
) -> list[BenchmarkItem]:
    """The first ``limit`` usable MindCube items of the file, with image paths resolved.

    An item with a missing image is skipped: a warning is logged and appended to ``skipped``.
    """
    image_root = Path(image_root) if image_root is not None else default_image_root(jsonl)
    items: list[BenchmarkItem] = []
    for number, record in _read_lines(jsonl):
        if limit is not None and len(items) >= limit:
            break
        where = f"{jsonl}:{number}"
        item_id = str(_require(record, ("id",), where))
        image_paths = [str(p) for p in _require(record, ("images",), where)]
        images = [_mindcube_image(p, image_root) for p in image_paths]
        missing = [str(p) for p in images if not p.is_file()]
        if missing:
            warning = f"{where}: skipping {item_id}: image not found: {missing[0]} (is the image root right?)"
            log.warning(warning)
            if skipped is not None:
                skipped.append(warning)
            continue
        items.append(
            BenchmarkItem(
                id=item_id,
                question=str(_require(record, ("question",), where)),
                gt_answer=str(_require(record, ("gt_answer", "answer"), where)),
                images=images,
                setting=setting_of(item_id, image_paths, record.get("category")),
                category=record.get("category"),
                type=record.get("type"),
                meta_info=record.get("meta_info") if record.get("meta_info") is not None else [],
                exact_scene=_exact_scene(record),
            )
        )
    return items


def read_omni3d(jsonl: Path, image_root: Path, limit: int | None = None) -> list[BenchmarkItem]:
    """Omni3D-Bench items: ``answer_type`` is int (counts), float (other numbers) or str."""
    items: list[BenchmarkItem] = []
    for number, record in _read_lines(jsonl):
        if limit is not None and len(items) >= limit:
            break
        where = f"{jsonl}:{number}"
        image_field = _require(record, ("images", "image", "image_path"), where)
        image_paths = [str(p) for p in image_field] if isinstance(image_field, list) else [str(image_field)]
        item_id = record.get("id", record.get("question_index", record.get("index", number)))
        items.append(
            BenchmarkItem(
                id=str(item_id),
                question=str(_require(record, ("question",), where)),
                gt_answer=str(_require(record, ("answer", "gt_answer"), where)),
                images=_resolve_images(image_paths, image_root, where),
                answer_type=str(_require(record, ("answer_type",), where)).lower(),
                meta_info=record.get("meta_info") or {},
            )
        )
    return items
