"""The real-model bench, run against the scripted OpenAI-compatible server (the only stand-in).

No model weights can be downloaded here, so the bench is proven on the scripted server: it must
start the services, ask both systems every question, and report the stage counts, seconds and
tokens. BENCHMARKS.md has the command for a machine with a local GGUF model.
"""

from __future__ import annotations

import pytest

from bench import real_model
from tests.support.model_replies import recorded_replies
from tests.support.scripted_llm import ScriptedLLM

MOTION_REPLY = """Describe the motion.
```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.describe_camera_motion(recon)
```
Example usage:
```python
print(program(input_scene))
```"""
# The repair of question 2 (a turn from image 1 to image 4): the pair's own sentence.
PAIR_REPLY = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.describe_camera_motion(recon, 1, 4)
```"""


def test_bench_reports_both_systems_on_the_same_questions(llm: ScriptedLLM, monkeypatch, capsys) -> None:
    llm.reset()
    llm.text_only()  # a llama.cpp-like server: list content is refused, so text-only must be on
    recorded_no_program = recorded_replies()[18].script_entry()
    # Question 2 asks about image 1 -> image 4: the consecutive sentences do not cover it, so the
    # asked-view check sends the first program back and the repair names the pair.
    replies = [recorded_no_program, MOTION_REPLY, MOTION_REPLY, PAIR_REPLY, MOTION_REPLY, MOTION_REPLY]
    llm.script(replies, model="qwen")
    monkeypatch.setenv("PYSPATIAL_CODE_MODEL", "qwen")
    monkeypatch.setenv("PYSPATIAL_CODE_MODEL_BASE_URL", llm.base_url)
    monkeypatch.setenv("PYSPATIAL_CODE_MODEL_TEXT_ONLY", "true")
    # A text-only answer model reads the text clues (its own queue on the same server).
    llm.script(['{"reasoning": "The output says so.", "answer": "A"}'] * 4, model="reader")
    monkeypatch.setenv("PYSPATIAL_ANSWER_MODEL", "reader")
    monkeypatch.setenv("PYSPATIAL_ANSWER_MODEL_BASE_URL", llm.base_url)
    monkeypatch.setenv("PYSPATIAL_ANSWER_MODEL_TEXT_ONLY", "true")
    assert (
        real_model.main(
            ["--questions", "4", "--max-repairs", "1", "--width", "160", "--height", "120", "--all-families"]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert (
        "Real code model: qwen (text only)" in out and "(+ reader)" in out and "4 synthetic questions" in out
    )
    rows = [line for line in out.splitlines() if line.startswith("| qwen") or line.startswith("| offline")]
    model_row, offline_row = ([cell.strip() for cell in row.strip("|").split("|")] for row in rows[:2])
    header = [cell.strip() for cell in out.splitlines()[2].strip("|").split("|")]
    model = dict(zip(header, model_row, strict=True))
    offline = dict(zip(header, offline_row, strict=True))
    assert model["questions"] == offline["questions"] == "4"
    # Question 1: the recorded prose reply (no program), then a repair; question 2: a clue about other
    # pairs, then the repair; the others: one attempt each.
    assert (model["attempts"], model["parsed"], model["validated"], model["ran"]) == ("6", "5", "5", "4")
    assert model["repairs"] == "2" and model["fallbacks"] == "0" and model["failed requests"] == "0"
    assert model["planner fallbacks"] == "0"
    assert int(model["code tokens in/out"].split("/")[0]) > 0
    assert model["answered"] == "4" and int(model["answer tokens in/out"].split("/")[1]) > 0
    assert offline["parsed"] == "0" and offline["attempts"] == "4"  # the planner's attempts have no reply
    assert int(model["correct"]) <= int(model["answered"]) <= 4
    assert "no_program 1" in out and "wrong_view 1" in out
    assert "| rotation_0000_turn_01 | 1 -> 4 | repaired-model | 2 | wrong_view |" in out
    assert len(llm.requests()) == 10  # 6 code + 4 answer requests, all plain strings: no refusal, no retry
    assert all(isinstance(r["messages"][0]["content"], str) for r in llm.requests())


def test_bench_needs_a_model(monkeypatch) -> None:
    monkeypatch.setenv("PYSPATIAL_CODE_MODEL", "")
    with pytest.raises(SystemExit, match="PYSPATIAL_CODE_MODEL"):
        real_model.main(["--questions", "1"])
