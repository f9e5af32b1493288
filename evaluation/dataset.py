"""Read benchmark questions from JSONL: MindCube's schema, and Omni3D-Bench's (one image per item).

MindCube lines carry ``id, question, gt_answer, images, category, type, meta_info``; image paths
are relative to an image root. Omni3D-Bench lines carry ``question, answer, answer_type`` and one
image; their ids and field names vary between exports, so a few spellings are accepted.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

MINDCUBE_SETTINGS = ("rotation", "among", "around")
UNKNOWN_SETTING = "other"


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
    meta_info: dict[str, Any] = field(default_factory=dict)


def setting_of(item_id: str, image_paths: list[str], category: Any = None) -> str:
    """The MindCube setting, read from the id prefix ("among_0012_..."), else from the image paths.

    MindCube names its ids and image folders after the setting; the category list is the last resort.
    """
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


def read_mindcube(jsonl: Path, image_root: Path, limit: int | None = None) -> list[BenchmarkItem]:
    """The first ``limit`` MindCube items of the file, with image paths resolved and checked."""
    items: list[BenchmarkItem] = []
    for number, record in _read_lines(jsonl):
        if limit is not None and len(items) >= limit:
            break
        where = f"{jsonl}:{number}"
        item_id = str(_require(record, ("id",), where))
        image_paths = list(_require(record, ("images",), where))
        items.append(
            BenchmarkItem(
                id=item_id,
                question=str(_require(record, ("question",), where)),
                gt_answer=str(_require(record, ("gt_answer", "answer"), where)),
                images=_resolve_images(image_paths, image_root, where),
                setting=setting_of(item_id, image_paths, record.get("category")),
                category=record.get("category"),
                type=record.get("type"),
                meta_info=record.get("meta_info") or {},
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
