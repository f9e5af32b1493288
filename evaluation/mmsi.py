"""MMSI-Bench: multi-image spatial questions from the published parquet file, scored by option letter.

The file (`MMSI_Bench.parquet`, hub dataset `RunsenXu/MMSI-Bench`) has one row per question:
`id`, `images` (a list of encoded image bytes), `question_type` (e.g. "Motion (Cam.)",
"Positional Relationship (Cam.–Cam.)"), `question` (its options inside, "Options: A: ..., B: ..."),
`answer` (the letter), `thought`, and optionally `difficulty` and `mean_normed_duration_seconds`.
It is read one row group at a time (pyarrow), each row's images written to files and checked to
decode, so that the images are never all in memory at once.

Two extractors score every reply: the project's (`answer_letter`, as `eval mindcube` uses it) and
the published one: after the post-prompt `PUBLISHED_POST_PROMPT`, the text inside double, then
single backticks, then braces is kept, and the first standalone A-D not followed by a word is the
letter (`published_letter`). Circular mode (`circular_items`) asks each question once per rotation
of its options; a question counts only when every rotation is right (OpenCompass's protocol).
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evaluation.answers import answer_letter
from evaluation.dataset import BenchmarkItem, DatasetError
from evaluation.metrics import Score
from evaluation.runner import run_items
from evaluation.solvers import Prediction, solve_safely
from shared.imaging.codecs import decode_image
from shared.questions.intent import parse_question

HUB_REPO = "RunsenXu/MMSI-Bench"
HUB_FILE = "MMSI_Bench.parquet"
REQUIRED_COLUMNS = ("id", "images", "question_type", "question", "answer", "thought")
OPTIONAL_COLUMNS = ("difficulty", "mean_normed_duration_seconds")
# The MMSI-Bench repository's post-prompt, as its README gives it (appended to the question).
PUBLISHED_POST_PROMPT = (
    "\nAnswer with the option's letter from the given choices directly. "
    "Enclose the option's letter within ``."
)
CIRCULAR_MARK = "@rot"
_OPTIONS_AT = re.compile(r"\bOptions\s*:\s*", re.IGNORECASE)
_MAX_IMAGE_BYTES = 50_000_000


@dataclass
class MMSIItem(BenchmarkItem):
    question_type: str = ""
    thought: str = ""
    difficulty: str | None = None
    duration_s: float | None = None
    source_id: str = ""  # the row's id; circular copies share it
    rotation: int = 0


def _image_suffix(data: bytes) -> str:
    return ".png" if data.startswith(b"\x89PNG") else ".jpg" if data.startswith(b"\xff\xd8") else ".img"


def _write_images(row_id: str, images: Any, image_dir: Path) -> list[Path]:
    if not isinstance(images, list) or not images:
        raise DatasetError(f"MMSI row {row_id}: `images` must be a non-empty list of image bytes")
    paths = []
    for index, data in enumerate(images):
        if not isinstance(data, bytes | bytearray):
            raise DatasetError(f"MMSI row {row_id}: image {index + 1} is {type(data).__name__}, not bytes")
        try:  # decoded once to check it, then dropped: only the file is kept
            decode_image(
                bytes(data), max_bytes=_MAX_IMAGE_BYTES, max_pixels=10**9, label=f"image {index + 1}"
            )
        except Exception as error:
            raise DatasetError(f"MMSI row {row_id}: image {index + 1} cannot be decoded: {error}") from error
        path = image_dir / f"{row_id}_{index}{_image_suffix(bytes(data))}"
        path.write_bytes(bytes(data))
        paths.append(path)
    return paths


def _checked_columns(parquet: Path) -> tuple[Any, list[str]]:
    import pyarrow.parquet as pq  # here, not at import: every pyspatial command imports this module

    try:
        table_file = pq.ParquetFile(parquet)
    except Exception as error:
        raise DatasetError(f"{parquet} is not a readable parquet file: {error}") from error
    names = table_file.schema_arrow.names
    missing = [name for name in REQUIRED_COLUMNS if name not in names]
    if missing:
        raise DatasetError(
            f"{parquet} lacks the MMSI-Bench column(s) {', '.join(missing)} (it has {', '.join(names)})"
        )
    return table_file, [*REQUIRED_COLUMNS, *(name for name in OPTIONAL_COLUMNS if name in names)]


def _item(row: dict[str, Any], image_dir: Path) -> MMSIItem:
    row_id = str(row["id"])
    duration = row.get("mean_normed_duration_seconds")
    return MMSIItem(
        id=row_id,
        question=str(row["question"]),
        gt_answer=str(row["answer"]).strip(),
        images=_write_images(row_id, row["images"], image_dir),
        setting=str(row["question_type"]),
        type=str(row["question_type"]),
        question_type=str(row["question_type"]),
        thought=str(row.get("thought") or ""),
        difficulty=None if row.get("difficulty") is None else str(row["difficulty"]),
        duration_s=None if duration is None else float(duration),
        source_id=row_id,
    )


def read_mmsi(
    parquet: Path, image_dir: Path, limit: int | None = None, types: list[str] | None = None
) -> list[MMSIItem]:
    """The questions (the first `limit` of the `types` asked for), images written under `image_dir`."""
    table_file, columns = _checked_columns(Path(parquet))
    image_dir.mkdir(parents=True, exist_ok=True)
    wanted = set(types) if types else None
    items: list[MMSIItem] = []
    for group in range(table_file.num_row_groups):
        for row in table_file.read_row_group(group, columns=columns).to_pylist():
            if wanted is not None and str(row["question_type"]) not in wanted:
                continue
            items.append(_item(row, image_dir))
            if limit is not None and len(items) >= limit:
                return items
    return items


def published_letter(reply: str | None) -> str | None:
    """The letter MMSI-Bench's own extraction reads from a reply (see the module docstring)."""
    text = reply or ""
    for pattern in (r"``([^`]*)``", r"`([^`]*)`", r"\{([^}]*)\}"):
        inside = re.search(pattern, text)
        if inside:
            text = inside.group(1)
    found = re.search(r"\b[A-D]\b(?!\s[a-zA-Z])", text)
    return found.group() if found else None


def rotated_question(question: str, shift: int) -> tuple[str, dict[str, str]]:
    """The question with its options rotated by `shift` ("A: x, B: y" -> "A: y, B: x"), and them."""
    marker = list(_OPTIONS_AT.finditer(question))
    if not marker:
        raise DatasetError(f"no 'Options:' in the question {question[:80]!r}")
    stem = question[: marker[-1].end()]
    options = parse_question(question).options  # the one question parser reads "Options: A: ..."
    if len(options) < 2:
        raise DatasetError(f"fewer than two options after 'Options:' in {question[:80]!r}")
    texts = list(options.values())
    texts = texts[shift:] + texts[:shift]
    rotated = dict(zip(options, texts, strict=True))
    return stem + ", ".join(f"{letter}: {text}" for letter, text in rotated.items()), rotated


def circular_items(items: list[MMSIItem]) -> list[MMSIItem]:
    """Each question once per rotation of its options, the true letter moved with its text."""
    copies = []
    for item in items:
        _, options = rotated_question(item.question, 0)
        truth = options.get(item.gt_answer)
        if truth is None:
            raise DatasetError(f"MMSI row {item.id}: answer {item.gt_answer!r} is not one of its options")
        for shift in range(len(options)):
            question, rotated = rotated_question(item.question, shift)
            letter = next(key for key, text in rotated.items() if text == truth)
            copies.append(_copy(item, f"{item.id}{CIRCULAR_MARK}{shift}", question, letter, shift))
    return copies


def _copy(item: MMSIItem, new_id: str, question: str, letter: str, shift: int) -> MMSIItem:
    fields = {key: value for key, value in item.__dict__.items() if key != "intent"}
    fields.update(id=new_id, question=question, gt_answer=letter, rotation=shift)
    return MMSIItem(**fields)


def score_mmsi(item: MMSIItem, prediction: Prediction, wall_s: float) -> dict[str, Any]:
    """One record: both extractors' letters and verdicts, the type, and what the solver did."""
    failed = prediction.error is not None
    ours = None if failed else answer_letter(prediction.answer, item.intent)
    published = None if failed else published_letter(prediction.answer)
    return {
        "id": item.id,
        "source_id": item.source_id,
        "rotation": item.rotation,
        "setting": item.question_type,
        "question_type": item.question_type,
        "difficulty": item.difficulty,
        "question": item.question,
        "gt_answer": item.gt_answer,
        "answer": ours,
        "prediction": ours,
        "correct": ours is not None and ours == item.gt_answer,
        "answered": ours is not None,
        "published_answer": published,
        "published_correct": published is not None and published == item.gt_answer,
        "refused": not failed and ours is None,
        "wall_s": wall_s,
        **prediction.as_record(),
    }


@dataclass
class TypeRow:
    accuracy: Score = field(default_factory=Score)  # the project's extractor, over all questions
    published: Score = field(default_factory=Score)  # MMSI-Bench's extraction
    answered: int = 0
    refused: int = 0
    errors: int = 0
    wall_s: float = 0.0


@dataclass
class MMSISummary:
    system: str
    circular: bool
    rows: dict[str, TypeRow]  # "overall" and each question type

    def as_dict(self) -> dict[str, Any]:
        return {
            "system": self.system,
            "circular": self.circular,
            "types": {
                name: {
                    "count": row.accuracy.count,
                    "accuracy": row.accuracy.value,
                    "accuracy_published_extraction": row.published.value,
                    "answered": row.answered,
                    "refused": row.refused,
                    "errors": row.errors,
                    "wall_s": round(row.wall_s, 3),
                }
                for name, row in self.rows.items()
            },
        }


def _questions(records: list[dict[str, Any]], circular: bool) -> list[dict[str, Any]]:
    """Per question one verdict: in circular mode right only if every rotation is right."""
    if not circular:
        return records
    grouped: dict[str, list[dict[str, Any]]] = {}
    for record in records:
        grouped.setdefault(str(record.get("source_id") or record["id"]), []).append(record)
    merged = []
    for source, group in grouped.items():
        merged.append(
            {
                "id": source,
                "question_type": group[0].get("question_type"),
                "correct": all(r.get("correct") for r in group),
                "published_correct": all(r.get("published_correct") for r in group),
                "answered": all(r.get("answered") for r in group),
                "refused": any(r.get("refused") for r in group),
                "error": next((r["error"] for r in group if r.get("error")), None),
                "wall_s": sum(float(r.get("wall_s") or 0.0) for r in group),
            }
        )
    return merged


def summarize_mmsi(
    records: list[dict[str, Any]], circular: bool = False, system: str | None = None
) -> MMSISummary:
    rows: dict[str, TypeRow] = {"overall": TypeRow()}
    for record in _questions(records, circular):
        for name in ("overall", str(record.get("question_type") or "unknown")):
            row = rows.setdefault(name, TypeRow())
            row.accuracy.add(float(bool(record.get("correct"))))
            row.published.add(float(bool(record.get("published_correct"))))
            row.answered += bool(record.get("answered"))
            row.refused += bool(record.get("refused"))
            row.errors += bool(record.get("error"))
            row.wall_s += float(record.get("wall_s") or 0.0)
    systems = {str(r.get("system")) for r in records if r.get("system")}
    return MMSISummary(system=system or ", ".join(sorted(systems)) or "none", circular=circular, rows=rows)


def _timed(solve: Callable[[BenchmarkItem], Prediction]) -> Callable[[MMSIItem], dict[str, Any]]:
    def evaluate(item: MMSIItem) -> dict[str, Any]:
        started = time.perf_counter()
        prediction = solve_safely(solve, item)
        return score_mmsi(item, prediction, time.perf_counter() - started)

    return evaluate


def evaluate_mmsi(
    items: list[MMSIItem],
    solve: Callable[[BenchmarkItem], Prediction],
    results_path: Path,
    circular: bool = False,
    concurrency: int = 4,
    resume: bool = False,
    console: Any = None,
    show_progress: bool = True,
) -> tuple[list[dict[str, Any]], MMSISummary]:
    """Run the items (their rotations in circular mode) and summarize per question type."""
    asked = circular_items(items) if circular else items
    records = run_items(
        asked,
        _timed(solve),
        results_path,
        concurrency=concurrency,
        resume=resume,
        console=console,
        show_progress=show_progress,
    )
    return records, summarize_mmsi(records, circular)


class RecordedReplies:
    """A solver that answers with replies recorded earlier (JSONL lines {"id", "reply"}): to score a
    model's saved outputs with both extractors without asking it again."""

    def __init__(self, path: Path, system: str = "recorded replies") -> None:
        self._replies: dict[str, str] = {}
        for number, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), 1):
            if not line.strip():
                continue
            try:
                record = json.loads(line)
                self._replies[str(record["id"])] = str(record["reply"])
            except (json.JSONDecodeError, KeyError, TypeError) as error:
                raise DatasetError(f"{path}:{number}: no JSON id and reply: {error}") from error
        self._system = system

    def solve(self, item: BenchmarkItem) -> Prediction:
        reply = self._replies.get(item.id)
        if reply is None:
            return Prediction(system=self._system, answer=None, error=f"no recorded reply for {item.id}")
        return Prediction(system=self._system, answer=reply, text=reply)


def fetch_parquet() -> Path:
    """MMSI_Bench.parquet through huggingface_hub's cache (downloaded once, then reused)."""
    from huggingface_hub import hf_hub_download

    return Path(hf_hub_download(repo_id=HUB_REPO, filename=HUB_FILE, repo_type="dataset"))
