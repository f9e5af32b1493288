"""The benchmark harness: answer normalization, metrics on hand-computed cases, the crash-safe runner,
the baseline against a scripted OpenAI-compatible server, and one run through the real services."""

from __future__ import annotations

import io
import json
import re
import time
import uuid
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from rich.console import Console
from typer.testing import CliRunner

import cli.eval_commands as eval_commands
from evaluation.answers import answer_letter, parse_number, parse_yes_no
from evaluation.dataset import BenchmarkItem, DatasetError, read_mindcube, read_omni3d, setting_of
from evaluation.metrics import mean_relative_accuracy, summarize_mindcube, summarize_omni3d
from evaluation.omni3d import score_omni3d
from evaluation.runner import read_results, run_items
from evaluation.solvers import Prediction
from shared.questions.intent import parse_question
from shared.synthetic import make_dataset
from tests.support.processes import running_service
from tests.support.scripted_llm import start_scripted_llm

QUESTION = "Where is the lamp? A. left B. right C. (the sofa side) D. behind"


# ---- answers ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("reply", "letter"),
    [
        ("C", "C"),
        ("C.", "C"),
        ("(C) the sofa", "C"),
        ("Answer: C", "C"),
        ("The answer is **B**", "B"),
        ("I think it is D", "D"),
        ("E", None),  # not one of the question's options
        ("no idea", None),
        ("", None),
        (None, None),
    ],
)
def test_answer_letters_are_normalized(reply, letter):
    assert answer_letter(reply, parse_question(QUESTION)) == letter


@pytest.mark.parametrize(
    ("text", "number"),
    [
        ("3", 3.0),
        ("about 2.5 m", 2.5),
        ("2.5m", 2.5),
        ("1 chair and 2 tables, so 3", 3.0),
        ("<ans>1,200</ans>", 1200.0),
        ("three", 3.0),
        ("-0.5", -0.5),
        ("no number here", None),
    ],
)
def test_numbers_are_parsed_from_free_text(text, number):
    assert parse_number(text) == number


def test_yes_no_parsing():
    assert parse_yes_no("Yes, it is taller.") == "yes"
    assert parse_yes_no("<ans>false</ans>") == "no"
    assert parse_yes_no("yes or no?") is None


# ---- metrics ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("prediction", "truth", "mra"),
    [
        (10.0, 10.0, 1.0),  # error 0 < 1 - t for all ten thresholds
        (9.6, 10.0, 1.0),  # error 0.04 < 0.05
        (10.5, 10.0, 0.9),  # error 0.05 is not < 0.05 (t = 0.95), but < 0.10
        (12.0, 10.0, 0.6),  # error 0.2 < 1 - t for t = 0.50 .. 0.75: six thresholds
        (3.0, 4.0, 0.5),  # error 0.25 < 1 - t for t = 0.50 .. 0.70: five
        (15.0, 10.0, 0.0),  # error 0.5 is not < 0.5
        (None, 10.0, 0.0),
        (0.0, 0.0, 1.0),
        (0.1, 0.0, 0.0),
    ],
)
def test_mean_relative_accuracy_hand_computed(prediction, truth, mra):
    assert mean_relative_accuracy(prediction, truth) == pytest.approx(mra)


def test_mindcube_accuracy_by_setting_hand_computed():
    timings = {"reconstruction_ms": 5.0, "codegen_ms": 1.0, "execution_ms": 100.0, "answering_ms": 3.0}
    base = {"program_produced": True, "executed": True, "answered": True, "timings": timings}
    records = [
        {**base, "id": "rotation_1", "setting": "rotation", "correct": True},
        {**base, "id": "rotation_2", "setting": "rotation", "correct": False},
        {**base, "id": "among_1", "setting": "among", "correct": True},
        {**base, "id": "among_2", "setting": "among", "correct": True},
        {**base, "id": "around_1", "setting": "around", "correct": False, "answered": False},
        # A failed request: no program, no timings, counted wrong.
        {"id": "among_3", "setting": "among", "correct": False, "error": "HTTP 502", "answered": False},
        {**base, "id": "around_2", "setting": "around", "correct": False, "executed": False, "timings": None},
    ]
    records[1]["timings"] = {**timings, "execution_ms": 400.0}
    summary = summarize_mindcube(records, system="test")
    assert summary.accuracy["overall"].value == pytest.approx(3 / 7)
    assert summary.accuracy["rotation"].value == pytest.approx(1 / 2)
    assert summary.accuracy["among"].value == pytest.approx(2 / 3)
    assert summary.accuracy["around"].value == 0.0
    # Stage rates count only the records where the stage applies (the failed request has no flags).
    assert summary.parse_success.value == 1.0 and summary.parse_success.count == 6
    assert summary.execution_success.value == pytest.approx(5 / 6)
    assert summary.answer_success.value == pytest.approx(5 / 7)
    assert summary.errors == 1
    assert summary.mean_ms["execution"] == pytest.approx((100 + 400 + 100 + 100 + 100) / 5)
    assert summary.mean_ms["codegen"] == pytest.approx(1.0)


def test_omni3d_scoring_hand_computed():
    def item(item_id, answer_type, gt):
        return BenchmarkItem(id=item_id, question="q", gt_answer=gt, images=[], answer_type=answer_type)

    def said(text):
        return Prediction(system="model", answer=text, text=text)

    records = [
        score_omni3d(item("1", "str", "yes"), said("Yes, it is.")),  # yes/no right
        score_omni3d(item("2", "str", "no"), said("<ans>yes</ans>")),  # yes/no wrong
        score_omni3d(item("3", "str", "chair"), said("The chair")),  # multiple choice right
        score_omni3d(item("4", "int", "4"), said("I count 4 mugs")),  # count right
        score_omni3d(item("5", "int", "4"), said("4.4")),  # count wrong: not exactly 4
        score_omni3d(item("6", "float", "10"), said("about 12 cm")),  # MRA 0.6
        score_omni3d(item("7", "float", "2.0"), said("2.0")),  # MRA 1.0
        score_omni3d(item("8", "float", "2.0"), Prediction(system="model", answer=None, error="HTTP 500")),
    ]
    assert [r["kind"] for r in records] == ["yes/no"] * 2 + ["multiple choice"] + ["count"] * 2 + [
        "numeric"
    ] * 3
    summary = summarize_omni3d(records)
    assert summary.by_kind["yes/no"].value == 0.5
    assert summary.by_kind["multiple choice"].value == 1.0
    assert summary.by_kind["count"].value == 0.5
    assert summary.by_kind["numeric"].value == pytest.approx((0.6 + 1.0 + 0.0) / 3)
    assert summary.errors == 1


def test_omni3d_items_are_read_with_their_answer_types(tmp_path):
    Image.fromarray(np.zeros((8, 8, 3), dtype=np.uint8)).save(tmp_path / "img.png")
    lines = [
        {"question_index": 7, "image": "img.png", "question": "How many?", "answer": 3, "answer_type": "int"},
        {"id": "b", "images": ["img.png"], "question": "Taller?", "answer": "yes", "answer_type": "str"},
    ]
    (tmp_path / "omni.jsonl").write_text("".join(json.dumps(line) + "\n" for line in lines))
    items = read_omni3d(tmp_path / "omni.jsonl", tmp_path)
    assert [(i.id, i.gt_answer, i.answer_type) for i in items] == [("7", "3", "int"), ("b", "yes", "str")]
    assert items[0].images == [tmp_path / "img.png"]
    with pytest.raises(DatasetError, match="image not found"):
        read_omni3d(tmp_path / "omni.jsonl", tmp_path / "elsewhere")


def test_setting_comes_from_the_id_prefix_or_the_image_path():
    assert setting_of("among_0012_motion_00", ["x.png"]) == "among"
    assert setting_of("q17", ["other_all_image/around/scene_3/1.jpg"]) == "around"
    assert setting_of("q18", ["rotation_set/1.jpg"]) == "rotation"
    assert setting_of("q19", ["a.png"], category=["Rotation", "turn"]) == "rotation"
    assert setting_of("q20", ["a.png"]) == "other"


# ---- the runner --------------------------------------------------------------------------------


def _items(count: int) -> list[BenchmarkItem]:
    return [BenchmarkItem(id=f"item{i}", question="q", gt_answer="A", images=[]) for i in range(count)]


class Interrupted(BaseException):
    """Stands for Ctrl-C or a kill: not an Exception, so the runner must not swallow it."""


def test_runner_writes_each_result_as_it_finishes_and_resumes(tmp_path):
    out = tmp_path / "results.jsonl"
    calls: list[str] = []

    def evaluate(item: BenchmarkItem) -> dict:
        # Finished items reach the disk while the run goes on, not at its end (one at a time here).
        deadline = time.monotonic() + 10
        while [r["id"] for r in read_results(out)] != calls:
            assert time.monotonic() < deadline, f"{calls} not on disk before {item.id}"
            time.sleep(0.01)
        if item.id == "item3":
            raise Interrupted
        calls.append(item.id)
        return {"id": item.id, "correct": True}

    with pytest.raises(Interrupted):
        run_items(_items(6), evaluate, out, concurrency=1, show_progress=False)
    assert [r["id"] for r in read_results(out)] == ["item0", "item1", "item2"]

    # The process died while writing a line: that torn line is dropped and its item redone.
    with out.open("a") as handle:
        handle.write('{"id": "item3", "corr')

    calls.clear()
    resumed: list[str] = []

    def evaluate_rest(item: BenchmarkItem) -> dict:
        resumed.append(item.id)
        return {"id": item.id, "correct": item.id != "item4"}

    records = run_items(_items(6), evaluate_rest, out, concurrency=2, resume=True, show_progress=False)
    assert sorted(resumed) == ["item3", "item4", "item5"]  # finished items were not redone
    assert [r["id"] for r in records] == [f"item{i}" for i in range(6)]
    on_disk = read_results(out)
    assert sorted(r["id"] for r in on_disk) == [f"item{i}" for i in range(6)]
    assert len(out.read_text().splitlines()) == 6


def test_runner_records_a_failing_item_and_goes_on(tmp_path):
    def evaluate(item: BenchmarkItem) -> dict:
        if item.id == "item1":
            raise RuntimeError("scene file vanished")
        return {"id": item.id, "correct": True}

    records = run_items(_items(3), evaluate, tmp_path / "r.jsonl", concurrency=2, show_progress=False)
    assert [r["correct"] for r in records] == [True, False, True]
    assert "scene file vanished" in records[1]["error"]


def test_a_fresh_run_replaces_an_old_results_file(tmp_path):
    out = tmp_path / "r.jsonl"
    out.write_text(json.dumps({"id": "item0", "correct": False}) + "\n")
    records = run_items(_items(1), lambda item: {"id": item.id, "correct": True}, out, show_progress=False)
    assert records == [{"id": "item0", "correct": True}]
    assert read_results(out) == records


# ---- the baseline (scripted OpenAI-compatible server) ---------------------------------------


def _write_tiny_mindcube(root: Path) -> Path:
    rng = np.random.default_rng(0)
    items = [
        ("rotation_01", "How did I turn? A. left B. right C. around", "B", 2),
        ("among_01", "Where did I move? A. forward B. back C. left D. right", "C", 2),
        ("around_01", "What is behind me? A. sofa B. lamp", "A", 1),
    ]
    lines = []
    for item_id, question, answer, views in items:
        paths = []
        for view in range(views):
            path = f"images/{item_id}_{view}.png"
            (root / path).parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)).save(root / path)
            paths.append(path)
        record = {
            "id": item_id,
            "question": question,
            "gt_answer": answer,
            "images": paths,
            "category": [item_id.split("_")[0]],
            "type": "test",
            "meta_info": {},
        }
        lines.append(json.dumps(record))
    jsonl = root / "items.jsonl"
    jsonl.write_text("\n".join(lines) + "\n")
    return jsonl


def _table_rows(output: str, system: str) -> list[list[str]]:
    """The cells of the printed table rows whose first cell is `system`."""
    rows = []
    for line in output.splitlines():
        cells = [c.strip() for c in re.split(r"[│┃|]", line)]
        cells = [c for c in cells if c]
        if cells and cells[0] == system:
            rows.append(cells)
    assert rows, f"no row {system!r} in:\n{output}"
    return rows


def _table_row(output: str, system: str) -> list[str]:
    """The cells of the first printed table row whose first cell is `system`."""
    return _table_rows(output, system)[0]


def _capture_console(monkeypatch) -> io.StringIO:
    buffer = io.StringIO()
    monkeypatch.setattr(eval_commands, "console", Console(file=buffer, width=200))
    return buffer


def test_baseline_refuses_without_an_answer_model(tmp_path, monkeypatch):
    jsonl = _write_tiny_mindcube(tmp_path)
    monkeypatch.delenv("PYSPATIAL_ANSWER_MODEL", raising=False)
    monkeypatch.chdir(tmp_path)  # no stray .env
    buffer = _capture_console(monkeypatch)
    result = CliRunner().invoke(
        eval_commands.eval_app, ["baseline", "--jsonl", str(jsonl), "--image-root", str(tmp_path)]
    )
    assert result.exit_code == 2
    assert "PYSPATIAL_ANSWER_MODEL" in buffer.getvalue()
    assert not (tmp_path / "baseline_results.jsonl").exists()


def test_baseline_asks_the_model_alone_and_compares_with_pyspatial(tmp_path, monkeypatch):
    jsonl = _write_tiny_mindcube(tmp_path)
    pyspatial_results = tmp_path / "pyspatial.jsonl"
    pyspatial_results.write_text(
        "".join(
            json.dumps({"id": i, "setting": s, "correct": c, "system": "vision-model + pySpatial"}) + "\n"
            for i, s, c in [
                ("rotation_01", "rotation", True),
                ("among_01", "among", True),
                ("around_01", "around", False),
            ]
        )
    )
    llm = start_scripted_llm()
    try:
        llm.script([{"text": "Answer: B"}, {"text": "(A) forward"}, {"text": "I cannot tell from these."}])
        monkeypatch.setenv("PYSPATIAL_ANSWER_MODEL", "vision-model")
        monkeypatch.setenv("PYSPATIAL_ANSWER_MODEL_BASE_URL", llm.base_url)
        buffer = _capture_console(monkeypatch)
        out = tmp_path / "baseline.jsonl"
        args = ["baseline", "--jsonl", str(jsonl), "--image-root", str(tmp_path), "--out", str(out)]
        args += ["--concurrency", "1", "--no-progress", "--compare", str(pyspatial_results)]
        result = CliRunner().invoke(eval_commands.eval_app, args)
        assert result.exit_code == 0, buffer.getvalue() + str(result.exception)
        requests = llm.requests()
    finally:
        llm.stop()

    records = {r["id"]: r for r in read_results(out)}
    assert records["rotation_01"]["prediction"] == "B" and records["rotation_01"]["correct"]
    assert records["among_01"]["prediction"] == "A" and not records["among_01"]["correct"]
    assert records["around_01"]["prediction"] is None and not records["around_01"]["answered"]
    # The model saw each question with its images, and nothing else.
    assert len(requests) == 3
    parts = requests[0]["messages"][0]["content"]
    assert parts[0]["text"].startswith("How did I turn?")
    assert [p["type"] for p in parts[1:]] == ["image_url", "image_url"]

    output = buffer.getvalue().split("Models")[0]
    # Two rows per system: over all items (MindCube's denominator), over answered items (the paper's).
    alone_all, alone_answered = _table_rows(output, "vision-model")
    assert alone_all[1:7] == ["all items (MindCube)", "3", "33.3", "100.0", "0.0", "0.0"]
    assert alone_answered[1:7] == ["answered (paper's code)", "2", "50.0", "100.0", "0.0", "-"]
    assert _table_row(output, "vision-model + pySpatial")[2:7] == ["3", "66.7", "100.0", "100.0", "0.0"]


# ---- end to end through the real services ----------------------------------------------------


def test_mindcube_harness_through_the_real_services_with_exact_depth(tmp_path, redis_url, monkeypatch):
    data = tmp_path / "bench"
    # Three scenes: one per setting (rotation, around, among), questions worded as MindCube's.
    jsonl = make_dataset(data, num_scenes=3, seed=3, width=128, height=96)
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path / "scenes"),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"test-eval-{uuid.uuid4().hex}",
    }
    out = tmp_path / "results.jsonl"
    buffer = _capture_console(monkeypatch)
    with running_service("services.recon.app:create_app", env) as recon:
        agent_env = {**env, "PYSPATIAL_RECON_URL": recon.url}
        with running_service("services.agent.app:create_app", agent_env) as agent:
            args = ["mindcube", "--jsonl", str(jsonl), "--image-root", str(data), "--out", str(out)]
            args += ["--agent-url", agent.url, "--recon-url", recon.url, "--backbone", "posed-rgbd"]
            args += ["--concurrency", "2", "--no-progress"]
            result = CliRunner().invoke(eval_commands.eval_app, args)
    output = buffer.getvalue()
    assert result.exit_code == 0, output + str(result.exception)

    items = {item.id: item for item in read_mindcube(jsonl, data)}
    records = read_results(out)
    assert sorted(r["id"] for r in records) == sorted(items)
    for record in records:
        assert record["error"] is None, record["error"]
        assert record["backbone"] == "posed-rgbd"
        assert record["gt_answer"] == items[record["id"]].gt_answer
        assert record["correct"] == (record["prediction"] == record["gt_answer"])
    # Exact cameras make every self-movement question answerable offline: all answered, all right,
    # each from the pair of views it asks about (every image is shown, so a wrong pair would show).
    truth = {json.loads(line)["id"]: json.loads(line) for line in jsonl.read_text().splitlines()}
    motion = [r for r in records if items[r["id"]].type in ("motion", "turn")]
    assert motion and all(r["answered"] and r["correct"] for r in motion)
    for record in motion:
        first, second = (v + 1 for v in truth[record["id"]]["pyspatial_scene"]["facts"]["pair"])
        assert record["family"] == "self_movement"
        assert f"describe_camera_motion(recon, {first}, {second})" in record["program"]
    # The other families need a vision model: no answer, never a guess.
    others = [r for r in records if r not in motion]
    assert others and not any(r["answered"] for r in others)
    # Records name what wrote the program and what answered; "answer" is MindCube's field.
    for record in records:
        assert record["code_model"] == "offline-planner" and record["answer_model"] == "offline-answerer"
        assert record["answer"] == record["prediction"] and record["fallback"] is None

    # The printed table agrees with correct / total computed by hand from the results file.
    def accuracy(rows: list[dict]) -> str:
        return f"{100.0 * sum(r['correct'] for r in rows) / len(rows):.1f}" if rows else "-"

    by_setting = {s: [r for r in records if r["setting"] == s] for s in ("rotation", "among", "around")}
    row = _table_row(output.split("Pipeline")[0], records[0]["system"])
    expected = [str(len(records)), accuracy(records), *(accuracy(by_setting[s]) for s in by_setting)]
    assert row[2:7] == expected
    pipeline = _table_row(output.split("Pipeline")[1], records[0]["system"])
    assert pipeline[1:5] == [
        accuracy([{"correct": r["program_produced"]} for r in records]),
        accuracy([{"correct": r["executed"]} for r in records]),
        accuracy([{"correct": r["answered"]} for r in records]),
        "0",
    ]
    assert {r["setting"] for r in records} == {"rotation", "around", "among"}
    models = _table_row(output.split("Models")[1], records[0]["system"])
    assert models[1:] == [f"offline-planner ({len(records)})", f"offline-answerer ({len(records)})", "0", "0"]
