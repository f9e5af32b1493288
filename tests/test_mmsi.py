"""`pyspatial eval mmsi` on a parquet file with MMSI-Bench's published schema, built from the
synthetic generator: reading in row groups, both extractors, circular scoring, resume, clear errors."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from cli.main import app
from evaluation.dataset import DatasetError
from evaluation.mmsi import (
    CIRCULAR_MARK,
    HUB_FILE,
    HUB_REPO,
    PUBLISHED_POST_PROMPT,
    RecordedReplies,
    circular_items,
    evaluate_mmsi,
    published_letter,
    read_mmsi,
    rotated_question,
)
from evaluation.solvers import Prediction
from shared.local.services import running_service
from shared.synthetic.mmsi import MOTION_CAM, MOTIONS, mmsi_rows, motion_word, moved_camera, write_parquet
from tests.support.hub_standin import HubStandIn
from tests.support.stack import recon_env


@pytest.fixture(scope="module")
def rows():
    return mmsi_rows(seed=3, scenes=3, size=(96, 72), motions=["down", "tilt up", "still"])


@pytest.fixture(scope="module")
def parquet(rows, tmp_path_factory):
    path = tmp_path_factory.mktemp("mmsi") / "MMSI_Bench.parquet"
    write_parquet(rows, path, row_group_size=4)
    return path


def test_the_published_schema_is_read_row_group_by_row_group(parquet, rows, tmp_path):
    assert pq.ParquetFile(parquet).num_row_groups >= 2
    items = read_mmsi(parquet, tmp_path / "images")
    assert [item.id for item in items] == [row["id"] for row in rows]
    first = items[0]
    assert first.question_type == MOTION_CAM and first.gt_answer in "ABCD" and len(first.images) == 2
    assert first.images[0].read_bytes() == rows[0]["images"][0] and first.difficulty == "easy"
    assert len(first.intent.options) == 4  # "Options: A: ..., B: ..." read by the question parser
    motion = read_mmsi(parquet, tmp_path / "again", limit=2, types=[MOTION_CAM])
    assert [item.question_type for item in motion] == [MOTION_CAM, MOTION_CAM]


def test_missing_columns_and_undecodable_images_fail_clearly(rows, tmp_path):
    table = pa.Table.from_pylist([{k: v for k, v in rows[0].items() if k != "thought"}])
    pq.write_table(table, tmp_path / "no_thought.parquet")
    with pytest.raises(DatasetError, match="lacks the MMSI-Bench column.*thought"):
        read_mmsi(tmp_path / "no_thought.parquet", tmp_path / "images")
    broken = dict(rows[0], images=[rows[0]["images"][0], b"not an image at all"])
    write_parquet([broken], tmp_path / "broken.parquet")
    with pytest.raises(DatasetError, match=f"row {rows[0]['id']}: image 2 cannot be decoded"):
        read_mmsi(tmp_path / "broken.parquet", tmp_path / "images")


@pytest.mark.parametrize(
    ("reply", "letter"),
    [
        ("`B`", "B"),
        ("``C``", "C"),
        ("The answer is {D}.", "D"),
        ("B", "B"),
        ("A. It moved down", "A"),
        ("A is my answer", None),  # a letter followed by a word is not taken
        ("I think it is C", "C"),
        ("no idea", None),
    ],
)
def test_the_published_extraction(reply, letter):
    assert published_letter(reply) == letter
    assert PUBLISHED_POST_PROMPT.startswith("\nAnswer with the option's letter")


def test_rotations_move_the_true_letter_with_its_text(parquet, tmp_path):
    [item] = read_mmsi(parquet, tmp_path / "images", limit=1)
    copies = circular_items([item])
    assert len(copies) == 4 and [c.rotation for c in copies] == [0, 1, 2, 3]
    truth = item.intent.options[item.gt_answer]
    for copy in copies:
        assert copy.intent.options[copy.gt_answer] == truth
        assert copy.id == f"{item.id}{CIRCULAR_MARK}{copy.rotation}"
    question, options = rotated_question(item.question, 1)
    assert list(options.values())[-1] == item.intent.options["A"] and "Options: A: " in question


def _replies(path, answers: dict[str, str]) -> RecordedReplies:
    path.write_text("".join(json.dumps({"id": k, "reply": v}) + "\n" for k, v in answers.items()))
    return RecordedReplies(path)


def test_recorded_replies_scored_with_both_extractors_plain_and_circular(parquet, tmp_path):
    items = read_mmsi(parquet, tmp_path / "images", limit=4)
    truth = {item.id: item.gt_answer for item in items}
    ids = list(truth)
    wrong = {"A": "B", "B": "C", "C": "D", "D": "A"}
    answers = {
        ids[0]: f"`{truth[ids[0]]}`",  # both extractors read it
        ids[1]: f"Answer: {truth[ids[1]]}. The camera moved.",  # both
        ids[2]: f"Answer: {truth[ids[2]]} is right",  # ours only: the published one skips "X is"
        ids[3]: f"`{wrong[truth[ids[3]]]}`",  # wrong for both
    }
    records, summary = evaluate_mmsi(
        items, _replies(tmp_path / "r.jsonl", answers).solve, tmp_path / "p.jsonl"
    )
    overall = summary.rows["overall"]
    assert overall.accuracy.count == 4 and overall.accuracy.total == 3 and overall.published.total == 2
    assert overall.answered == 4 and overall.refused == 0 and overall.errors == 0
    assert {r["id"]: r["published_answer"] for r in records}[ids[2]] is None
    circular = circular_items(items[:2])
    replies = {c.id: f"`{c.gt_answer}`" for c in circular}
    replies[circular[-1].id] = f"`{wrong[circular[-1].gt_answer]}`"  # question 2 misses one rotation
    _, summary = evaluate_mmsi(
        items[:2], _replies(tmp_path / "c.jsonl", replies).solve, tmp_path / "c_pred.jsonl", circular=True
    )
    assert summary.rows["overall"].accuracy.count == 2 and summary.rows["overall"].accuracy.total == 1
    assert summary.as_dict()["circular"] is True


def test_a_killed_run_resumes_where_it_stopped(parquet, tmp_path):
    items = read_mmsi(parquet, tmp_path / "images", limit=6)
    asked: list[str] = []

    def dies_after_three(item):
        if len(asked) == 3:
            raise KeyboardInterrupt  # the process is stopped mid-run
        asked.append(item.id)
        return Prediction(system="scripted", answer=item.gt_answer)

    out = tmp_path / "pred.jsonl"
    with pytest.raises(KeyboardInterrupt):
        evaluate_mmsi(items, dies_after_three, out, concurrency=1, show_progress=False)
    with out.open("a") as handle:
        handle.write('{"id": "torn')  # the line being written when it died
    done = [json.loads(line)["id"] for line in out.read_text().splitlines()[:-1]]
    assert done == [item.id for item in items[:3]]
    resumed: list[str] = []

    def answers(item):
        resumed.append(item.id)
        return Prediction(system="scripted", answer=item.gt_answer)

    records, summary = evaluate_mmsi(items, answers, out, resume=True, concurrency=1, show_progress=False)
    assert resumed == [item.id for item in items[3:]] and len(records) == 6
    assert summary.rows["overall"].accuracy.total == 6


def test_the_command_writes_predictions_and_a_summary(parquet, rows, tmp_path):
    items = read_mmsi(parquet, tmp_path / "images")
    replies = tmp_path / "replies.jsonl"
    replies.write_text("".join(json.dumps({"id": i.id, "reply": f"`{i.gt_answer}`"}) + "\n" for i in items))
    out = tmp_path / "run" / "mmsi.jsonl"
    result = CliRunner().invoke(
        app,
        [
            "eval",
            "mmsi",
            "--parquet",
            str(parquet),
            "--replies",
            str(replies),
            "--out",
            str(out),
            "--no-progress",
        ],
    )
    assert result.exit_code == 0, result.output
    summary = json.loads(out.with_suffix(".summary.json").read_text())
    assert (
        summary["types"]["overall"]["count"] == len(rows) and summary["types"]["overall"]["accuracy"] == 1.0
    )
    assert summary["types"][MOTION_CAM]["accuracy_published_extraction"] == 1.0
    assert len(out.read_text().splitlines()) == len(rows)
    failed = CliRunner().invoke(app, ["eval", "mmsi", "--out", str(out)])
    assert failed.exit_code == 2 and "exactly one of --parquet" in failed.output


@pytest.mark.parametrize("motion", list(MOTIONS))
def test_every_motion_word_the_generator_asks_is_what_camera_motion_says(motion):
    first = np.hstack([np.eye(3), np.array([[0.0], [1.5], [2.0]])])  # any valid camera
    assert motion_word(first, moved_camera(first, motion)) == motion


@pytest.mark.slow  # a CLI child process against the hub stand-in: about a minute on a busy machine
def test_fetch_pulls_the_parquet_through_huggingface_hub(parquet, tmp_path):
    hub = HubStandIn()
    hub.host(HUB_REPO, HUB_FILE, parquet)
    url = hub.start()
    try:
        items = read_mmsi(parquet, tmp_path / "images", limit=2)
        replies = tmp_path / "replies.jsonl"
        replies.write_text("".join(json.dumps({"id": i.id, "reply": i.gt_answer}) + "\n" for i in items))
        environment = {k: v for k, v in os.environ.items() if not k.startswith(("HF_", "PYSPATIAL_"))}
        environment.update(HF_HOME=str(tmp_path / "hf"), HF_ENDPOINT=url, HF_HUB_DISABLE_TELEMETRY="1")
        out = tmp_path / "fetched.jsonl"
        command = [sys.executable, "-m", "cli.main", "eval", "mmsi", "--fetch", "--limit", "2"]
        command += ["--replies", str(replies), "--out", str(out), "--no-progress"]
        done = subprocess.run(command, env=environment, capture_output=True, text=True, timeout=120)
    finally:
        hub.stop()
    assert done.returncode == 0, done.stdout + done.stderr
    assert any("datasets/RunsenXu/MMSI-Bench/resolve" in path for _, path, _ in hub.requests)
    assert json.loads(out.with_suffix(".summary.json").read_text())["types"]["overall"]["accuracy"] == 1.0


def test_a_run_killed_by_sigkill_resumes_where_it_stopped(parquet, rows, tmp_path, redis_url):
    """The command itself, asking a real agent and recon, is SIGKILLed after its first predictions;
    `--resume` then asks only the rest, and every question is in the file exactly once."""
    recon_settings = recon_env(tmp_path / "recon", redis_url, backbone="classical")
    out = tmp_path / "run" / "mmsi.jsonl"
    with (
        running_service("services.recon.app:create_app", recon_settings) as recon,
        running_service("services.agent.app:create_app", {"PYSPATIAL_RECON_URL": recon.url}) as agent,
    ):
        command = [sys.executable, "-m", "cli.main", "eval", "mmsi", "--parquet", str(parquet)]
        command += ["--agent-url", agent.url, "--out", str(out), "--concurrency", "1", "--no-progress"]
        environment = {k: v for k, v in os.environ.items() if not k.startswith("PYSPATIAL_")}
        first = subprocess.Popen(
            command, env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        deadline = time.monotonic() + 240
        while not (out.exists() and len(out.read_text().splitlines()) >= 2):
            assert first.poll() is None, "the run ended before it could be killed"
            assert time.monotonic() < deadline, "no predictions were written"
            time.sleep(0.05)
        first.send_signal(signal.SIGKILL)
        first.wait()
        before = [json.loads(line)["id"] for line in out.read_text().splitlines() if line.endswith("}")]
        assert 2 <= len(before) < len(rows)  # killed mid-run
        resumed = subprocess.run(
            [*command, "--resume"], env=environment, capture_output=True, text=True, timeout=600
        )
        assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    ids = [json.loads(line)["id"] for line in out.read_text().splitlines()]
    assert sorted(ids) == sorted(row["id"] for row in rows)  # each question once, none lost
    assert ids[: len(before)] == before  # what was done before the kill was kept, not asked again
    summary = json.loads(out.with_suffix(".summary.json").read_text())
    assert summary["types"]["overall"]["count"] == len(rows)
