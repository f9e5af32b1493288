"""The live real-model run of BENCHMARKS.md, replayed without the model.

`tests/data/model_replies/live_seed22.json` is what `python -m bench.real_model --seed 22 --record`
measured on the local Qwen2.5-Coder-1.5B (../shared/local_model/, text only, offline answerer): per
question the program source, the answer and the model's replies; and `replies`, every reply of the
model server in the order it was asked (its own call log, with finish reasons and token counts). The
scripted server replays those replies to the same bench on the same questions, so the loop (asked-
view check, pointed repairs, identical repairs, the labelled planner fallback) must come to the
same program sources and answers as it did live. The first questions run by default; all of them
with `-m slow`.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import real_model
from tests.support.scripted_llm import ScriptedLLM

LIVE = Path(__file__).parent / "data" / "model_replies" / "live_seed22.json"


def _live() -> dict:
    return json.loads(LIVE.read_text(encoding="utf-8"))


def _run_on_replies(llm: ScriptedLLM, monkeypatch, tmp_path: Path, live: dict, arguments: list[str]) -> dict:
    """bench.real_model with `arguments`, its code model the scripted server replaying `live`'s replies."""
    facts = live["record"]
    llm.reset()
    llm.text_only()
    llm.script(live["replies"], model=facts["model"])
    monkeypatch.setenv("PYSPATIAL_CODE_MODEL", facts["model"])
    monkeypatch.setenv("PYSPATIAL_CODE_MODEL_BASE_URL", llm.base_url)
    monkeypatch.setenv("PYSPATIAL_CODE_MODEL_TEXT_ONLY", "true")
    monkeypatch.setenv("PYSPATIAL_ANSWER_MODEL", "")
    record = tmp_path / "replayed.json"
    assert real_model.main([*arguments, "--record", str(record)]) == 0
    replayed = json.loads(record.read_text(encoding="utf-8"))
    assert replayed["prompt"] == facts["prompt"], "the code prompt changed since the live run"
    return replayed


def _replay(llm: ScriptedLLM, monkeypatch, tmp_path: Path, questions: int) -> list[dict]:
    live = _live()
    facts = live["record"]
    arguments = ["--questions", str(questions), "--seed", str(facts["seed"])]
    arguments += ["--width", str(facts["width"]), "--height", str(facts["height"])]
    replayed = _run_on_replies(llm, monkeypatch, tmp_path, live, arguments)
    return replayed["results"]


def _outcomes(results: list[dict]) -> list[tuple]:
    return [(r["id"], r["program_source"], r["answer"], r["model_replies"]) for r in results]


def test_the_first_live_questions_replay_to_the_same_outcomes(llm, monkeypatch, tmp_path) -> None:
    results = _replay(llm, monkeypatch, tmp_path, 4)
    assert _outcomes(results) == _outcomes(_live()["record"]["results"][:4])
    assert all(r["program_source"] is not None for r in results)  # every source is named


@pytest.mark.slow
def test_the_whole_live_run_replays_to_the_same_outcomes(llm, monkeypatch, tmp_path) -> None:
    live = _live()["record"]["results"]
    assert _outcomes(_replay(llm, monkeypatch, tmp_path, len(live))) == _outcomes(live)


HELDOUT_LIVE = Path(__file__).parent / "data" / "paraphrases" / "heldout_live_v4.json"


@pytest.mark.slow
def test_the_held_out_live_run_replays_with_no_wrong_answer(llm, monkeypatch, tmp_path) -> None:
    """The live run on reworded real-photo questions (held-out wordings), replayed on today's code.

    The model's replies are the same, so program sources and replies are the same as live until
    today's loop asks for a reply more or less (the question whose request failed live, a client
    timeout, is left out of that). The reading and the checks may have changed since, so answers may
    differ, but none may be wrong, and no fewer questions may be answered than live.
    """
    from bench.mmsi_templering import mmsi_rows
    from bench.templering_data import realdata_dir
    from shared.synthetic.mmsi import write_parquet

    assert realdata_dir() is not None, "templeRing not found: ../shared/realdata or PYSPATIAL_REALDATA_DIR"
    live = json.loads(HELDOUT_LIVE.read_text(encoding="utf-8"))
    recorded = live["record"]["results"]
    rows = mmsi_rows("heldout", limit=len(recorded))
    truth = {row["id"]: row["answer"] for row in rows}
    parquet = tmp_path / "heldout.parquet"
    write_parquet(rows, parquet)
    arguments = ["--questions", str(len(recorded)), "--parquet", str(parquet)]
    results = _run_on_replies(llm, monkeypatch, tmp_path, live, arguments)["results"]
    assert [r["id"] for r in results] == [r["id"] for r in recorded]
    # The replies come in the order the live loop asked for them: up to the first question where
    # today's loop asks for a different number of them (a check added since sends a program back),
    # every question gets the same replies and program source as live; that question got the live
    # replies first. After it, the replies no longer belong to their questions: only the answers count.
    failed_live = {r["id"] for r in recorded if r["program_source"] is None and not r["model_replies"]}
    for now, then in zip(results, recorded, strict=True):
        if now["id"] in failed_live:
            continue
        if now["model_replies"] != then["model_replies"]:
            assert now["model_replies"][: len(then["model_replies"])] == then["model_replies"], now["id"]
            break
        assert now["program_source"] == then["program_source"], now["id"]
    wrong = [r["id"] for r in results if r["answer"] is not None and r["answer"] != truth[r["id"]]]
    assert wrong == []
    assert sum(r["answer"] is not None for r in results) >= sum(r["answer"] is not None for r in recorded)
