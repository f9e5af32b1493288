"""The solve as typed step records: the SSE stream is built from them, and the response carries them.

Real recon and agent processes, real Redis, real rendered images with exact cameras (posed-rgbd); the
code and answer models are the scripted OpenAI-compatible server. The expected event lists were
recorded from the solve before it was split into stages (main at e45e93a, see RECORDED_ON), so the
stream a page or the CLI sees is the same event for event, details included.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass

import httpx
import pytest

from services.agent.progress import StageReporter
from services.agent.steps import SolveLog, StepCallbacks
from shared.local.services import ServiceProcess, running_service
from shared.questions.reading import read_question
from shared.wire import schemas
from shared.wire.client import AgentClient
from shared.wire.schemas import SolveResponse, StageEvent
from tests.support.scenes import PosedViews, orbit_views
from tests.support.stack import recon_env, upload_posed_views
from tests.test_model_endpoints import MOTION_REPLY

RECORDED_ON = "e45e93a"
MOTION_QUESTION = (
    "Which way did the camera move from view 1 to view 2? A. left B. right C. forward D. backward"
)
# Since issue 34 the answer's stage event repeats how a camera question was read.
MOTION_READ = f" ({read_question(MOTION_QUESTION, 3).summary})"
SHAPE_ERROR_REPLY = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return str(recon.extrinsics[0] @ [1.0, 2.0, 3.0])
```"""
ANSWER_REPLY = '{"reasoning": "The output says the camera moved.", "answer": "B"}'


@dataclass
class Stack:
    views: PosedViews
    scene_id: str  # the posed views, uploaded
    offline_agent: ServiceProcess  # no models: the offline planner and answerer
    model_agent: ServiceProcess  # scripted code model "coder" and answer model "answerer"


@pytest.fixture(scope="module")
def stack(tmp_path_factory, redis_url, llm) -> Iterator[Stack]:
    views = orbit_views(seed=5, num_views=3)
    scripted = {"PYSPATIAL_MODEL_TIMEOUT_S": "5", "PYSPATIAL_MODEL_MAX_RETRIES": "0"}
    for role, name in (("CODE", "coder"), ("ANSWER", "answerer")):
        scripted |= {f"PYSPATIAL_{role}_MODEL": name, f"PYSPATIAL_{role}_MODEL_BASE_URL": llm.base_url}
    with ExitStack() as services:
        recon_settings = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
        recon = services.enter_context(running_service("services.recon.app:create_app", recon_settings))
        agents = [
            services.enter_context(
                running_service("services.agent.app:create_app", {"PYSPATIAL_RECON_URL": recon.url, **models})
            )
            for models in ({"PYSPATIAL_CODE_MODEL": "", "PYSPATIAL_ANSWER_MODEL": ""}, scripted)
        ]
        yield Stack(views, upload_posed_views(recon.url, views), *agents)


RECONSTRUCTED = [
    ("upload", "started", "scene <scene>"),
    ("upload", "done", "scene <scene>"),
    ("reconstruction", "started", "service default backbone"),
    ("reconstruction", "done", "posed-rgbd: 3 of 3 views placed, 57600 points"),
]
# Recorded from the solve of RECORDED_ON, event for event (details normalized by _normalized).
OFFLINE_PLANNER_EVENTS = [
    *RECONSTRUCTED,
    ("program", "started", "writing a program with offline-planner"),
    ("program", "done", "attempt 1 written"),
    ("execution", "started", "running attempt 1 in the sandbox"),
    ("execution", "done", "attempt 1 ran"),
    ("answer", "started", "answering with offline-answerer" + MOTION_READ),
    ("answer", "done", "B"),
]
REPAIRED_EVENTS = [
    *RECONSTRUCTED,
    ("program", "started", "writing a program with coder"),
    ("program", "done", "attempt 1 written"),
    ("execution", "started", "running attempt 1 in the sandbox"),
    ("execution", "failed", "program raised ValueError"),
    ("program", "started", "asking coder to repair attempt 1"),
    ("program", "done", "attempt 2 written"),
    ("execution", "started", "running attempt 2 in the sandbox"),
    ("execution", "done", "attempt 2 ran"),
    ("answer", "started", "answering with answerer" + MOTION_READ),
    ("answer", "done", "B"),
]
UNPLANNABLE = (
    "the offline planner has no program for this question: an occlusion question (what hides what, "
    "what is visible) is about objects in the photos; no tool output states it in words, so only a "
    "vision model can answer it"
)
IMAGES_ONLY_EVENTS = [
    *RECONSTRUCTED,
    ("program", "started", "writing a program with coder"),
    ("program", "done", "attempt 1 written"),
    ("execution", "started", "running attempt 1 in the sandbox"),
    ("execution", "failed", "program raised ValueError"),
    ("program", "started", "the code model's attempts failed: offline planner"),
    ("program", "failed", UNPLANNABLE),
    ("answer", "started", "answering from the photos alone with answerer"),
    ("answer", "done", "A"),
]
# The model's only attempt fails and the planner has a program: it runs, labelled as the planner's.
PLANNER_FALLBACK_EVENTS = [
    *RECONSTRUCTED,
    ("program", "started", "writing a program with coder"),
    ("program", "done", "attempt 1 written"),
    ("execution", "started", "running attempt 1 in the sandbox"),
    ("execution", "failed", "program raised ValueError"),
    ("program", "started", "the code model's attempts failed: offline planner"),
    ("program", "done", "attempt 2 written by the offline planner (fallback)"),
    ("execution", "started", "running attempt 2 in the sandbox"),
    ("execution", "done", "attempt 2 ran"),
    ("answer", "started", "answering with answerer" + MOTION_READ),
    ("answer", "done", "B"),
]
CANNOT_RECONSTRUCT = (
    "the posed-rgbd backbone could not reconstruct the scene: backbone posed-rgbd cannot reconstruct "
    "this scene: posed-rgbd needs depths, extrinsics and intrinsics for every view; missing: depths, "
    "extrinsics, intrinsics"
)
RECONSTRUCTION_422_EVENTS = [
    ("upload", "started", "3 images"),
    ("upload", "done", "scene <scene>"),
    ("reconstruction", "started", "posed-rgbd"),
    ("reconstruction", "failed", CANNOT_RECONSTRUCT),
    ("answer", "failed", CANNOT_RECONSTRUCT + "; answering from the photos alone needs an answer model "
     "(PYSPATIAL_ANSWER_MODEL)"),
]  # fmt: skip
UNPLANNABLE_EVENTS = [
    *RECONSTRUCTED,
    ("program", "started", "writing a program with offline-planner"),
    ("program", "failed", UNPLANNABLE),
    ("answer", "started", "answering with offline-answerer"),
    ("answer", "failed", f"no program ran successfully: {UNPLANNABLE}; answering from the photos alone needs "
     "an answer model (PYSPATIAL_ANSWER_MODEL)"),
]  # fmt: skip
# A reply without a program is not an event: the program stage stays open while the model is asked again.
NO_PROGRAM_FIRST_EVENTS = [
    *RECONSTRUCTED,
    ("program", "started", "writing a program with coder"),
    ("program", "done", "attempt 1 written"),
    ("execution", "started", "running attempt 1 in the sandbox"),
    ("execution", "done", "attempt 1 ran"),
    ("answer", "started", "answering with answerer" + MOTION_READ),
    ("answer", "done", "B"),
]
OCCLUSION_QUESTION = (
    "From the viewpoint presented in image 1, which object is hidden behind the table? "
    "A. The sofa B. The lamp"
)


def _normalized(detail: str, scene: str | None) -> str:
    detail = detail.replace(" (cached)", "")  # whether an earlier solve already reconstructed it
    if detail.startswith("program raised "):
        detail = detail.split(":")[0]  # numpy's wording of the error is not ours
    return detail.replace(scene, "<scene>") if scene else detail


def solve_streamed(agent, **request) -> tuple[list[tuple[str, str, str]], SolveResponse]:
    seen: list[StageEvent] = []
    with AgentClient(agent.url) as client:
        result = client.solve_with_progress(on_stage=seen.append, **request)
    return [(e.stage, e.state, _normalized(e.detail, result.scene_id)) for e in seen], result


def replayed(result: SolveResponse) -> list[tuple[str, str, str]]:
    """The stage events the response's own step records make, each started then finished in turn."""
    events: list[tuple[str, str, str]] = []
    reporter = StageReporter(lambda stage, state, detail: events.append((stage, state, detail)))
    callbacks = StepCallbacks()
    reporter.watch(callbacks)
    for step in result.steps:
        callbacks.notify(step, "started")
        callbacks.notify(step, "finished")
    return [(stage, state, _normalized(detail, result.scene_id)) for stage, state, detail in events]


def kinds(result: SolveResponse) -> list[str]:
    return [step.kind for step in result.steps]


def assert_timed(result: SolveResponse) -> None:
    starts = [step.started_ms for step in result.steps]
    assert starts == sorted(starts) and all(step.duration_ms >= 0 for step in result.steps)
    for earlier, later in zip(result.steps, result.steps[1:], strict=False):  # one step at a time
        assert earlier.started_ms + earlier.duration_ms <= later.started_ms + 0.05
    timings = result.timings
    by_kind = {
        kind: sum(s.duration_ms for s in result.steps if s.kind == kind) for kind in set(kinds(result))
    }
    assert timings.reconstruction_ms == pytest.approx(by_kind.get("reconstruction", 0.0), abs=0.05)
    assert timings.codegen_ms == pytest.approx(by_kind.get("program", 0.0), abs=0.05)
    assert timings.execution_ms == pytest.approx(by_kind.get("execution", 0.0), abs=0.05)
    assert timings.answering_ms == pytest.approx(by_kind.get("answer", 0.0), abs=0.05)
    assert result.steps[-1].started_ms + result.steps[-1].duration_ms <= timings.total_ms


def test_offline_planner_stream_is_as_recorded_and_made_of_the_steps(stack):
    events, result = solve_streamed(stack.offline_agent, question=MOTION_QUESTION, scene_id=stack.scene_id)
    assert events == OFFLINE_PLANNER_EVENTS
    assert replayed(result) == events
    assert kinds(result) == ["scene", "reconstruction", "program", "execution", "answer"]
    scene, recon, program, execution, answer = result.steps
    assert isinstance(scene, schemas.SceneStep) and scene.scene_id == stack.scene_id and scene.num_images == 3
    assert isinstance(recon, schemas.ReconstructionStep) and (recon.views_placed, recon.num_views) == (3, 3)
    assert isinstance(program, schemas.ProgramStep) and program.author == "offline-planner"
    assert program.program == result.program and program.error is None
    assert (
        isinstance(execution, schemas.ExecutionStep)
        and execution.ok
        and execution.run == execution.attempt == 1
    )
    assert execution.clue_text == result.clue.text and execution.clue_images == 0
    assert isinstance(answer, schemas.AnswerStep) and answer.answer == result.answer == "B"
    assert answer.answered_by == result.answer_model == "offline-answerer"
    assert_timed(result)


def test_a_repaired_attempt_is_two_programs_and_two_runs(stack, llm):
    llm.reset()
    llm.script([SHAPE_ERROR_REPLY, MOTION_REPLY], model="coder")
    llm.script([ANSWER_REPLY], model="answerer")
    events, result = solve_streamed(
        stack.model_agent, question=MOTION_QUESTION, scene_id=stack.scene_id, max_repairs=2
    )
    assert events == REPAIRED_EVENTS
    assert replayed(result) == events
    assert kinds(result) == [
        "scene",
        "reconstruction",
        "program",
        "execution",
        "program",
        "execution",
        "answer",
    ]
    first, failed, repair, ran = result.steps[2:6]
    assert (first.attempt, first.author, first.repairs) == (1, "coder", None)
    assert failed.ok is False and failed.error_kind == "exception" and failed.run == 1
    assert failed.error.startswith("program raised ValueError") and failed.error == result.attempts[0].error
    assert (repair.attempt, repair.repairs) == (2, 1) and repair.program == result.program
    assert ran.ok and ran.run == ran.attempt == 2 and ran.error is None
    answer = result.steps[-1]
    assert answer.answer == "B" and answer.answered_by == "answerer" and answer.prompt_tokens > 0
    assert result.tokens.answer_prompt == answer.prompt_tokens
    assert_timed(result)


def test_images_only_fallback_is_an_answer_step_from_the_photos(stack, llm):
    llm.reset()
    llm.script([SHAPE_ERROR_REPLY], model="coder")
    llm.script(['{"reasoning": "from the photos", "answer": "A"}'], model="answerer")
    events, result = solve_streamed(
        stack.model_agent, question=OCCLUSION_QUESTION, scene_id=stack.scene_id, max_repairs=0
    )
    assert events == IMAGES_ONLY_EVENTS
    assert replayed(result) == events
    assert kinds(result) == ["scene", "reconstruction", "program", "execution", "program", "answer"]
    assert result.steps[4].fallback and result.steps[4].error_kind == "unplannable"
    assert result.program_source is None
    answer = result.steps[-1]
    assert answer.from_photos and answer.answerer == "answerer" and answer.answer == "A"
    assert result.fallback == "images_only" and result.program is None
    assert result.steps[3].error == result.attempts[0].error
    assert_timed(result)


def test_planner_fallback_after_the_models_attempts_is_labelled(stack, llm):
    llm.reset()
    llm.script([SHAPE_ERROR_REPLY], model="coder")
    llm.script([ANSWER_REPLY], model="answerer")
    events, result = solve_streamed(
        stack.model_agent, question=MOTION_QUESTION, scene_id=stack.scene_id, max_repairs=0
    )
    assert events == PLANNER_FALLBACK_EVENTS
    assert replayed(result) == events
    assert result.program_source == "planner" and result.code_model.startswith("offline-planner (fallback")
    assert "coder's 1 attempt(s) failed" in result.code_model_fallback
    model_attempt, planner_attempt = result.attempts  # the model's attempt stays in the record
    assert model_attempt.reply is not None and "ValueError" in model_attempt.error
    assert planner_attempt.reply is None and planner_attempt.program == result.program
    assert "describe_camera_motion(recon, 1, 2)" in result.program
    program_steps = [s for s in result.steps if s.kind == "program"]
    assert [(s.author, s.fallback) for s in program_steps] == [("coder", False), ("offline-planner", True)]


def test_a_scene_the_backbone_cannot_reconstruct(stack):
    events, result = solve_streamed(
        stack.offline_agent, question=MOTION_QUESTION, images=stack.views.pngs(), backbone="posed-rgbd"
    )
    assert events == RECONSTRUCTION_422_EVENTS
    assert replayed(result) == events
    assert kinds(result) == ["scene", "reconstruction", "answer"]
    scene, recon, answer = result.steps
    assert scene.uploaded_images == 3 and recon.requested_backbone == "posed-rgbd"
    assert recon.error == CANNOT_RECONSTRUCT and recon.backbone == "posed-rgbd"
    assert answer.answerer is None and answer.from_photos and answer.error == result.answer_reason
    assert_timed(result)


def test_unplannable_question_and_a_reply_without_a_program(stack, llm):
    events, result = solve_streamed(stack.offline_agent, question=OCCLUSION_QUESTION, scene_id=stack.scene_id)
    assert events == UNPLANNABLE_EVENTS and replayed(result) == events
    planner = result.steps[2]
    assert planner.error_kind == "unplannable" and planner.program is None and planner.error == UNPLANNABLE

    llm.reset()
    llm.script(["I would describe the camera motion.", MOTION_REPLY], model="coder")
    llm.script([ANSWER_REPLY], model="answerer")
    events, result = solve_streamed(
        stack.model_agent, question=MOTION_QUESTION, scene_id=stack.scene_id, max_repairs=2
    )
    assert events == NO_PROGRAM_FIRST_EVENTS and replayed(result) == events
    no_program, written = result.steps[2:4]
    assert no_program.kind == written.kind == "program"
    assert no_program.error_kind == "no_program" and no_program.program is None and written.attempt == 2


def test_a_repair_is_announced_only_when_the_model_is_asked_again(stack, llm):
    """The one place the stream differs from RECORDED_ON: there, a failed run on the last request
    still sent "asking coder to repair attempt 1" although no request followed (a reply without a
    program had used up the repairs); the stream built from the records only says what happened."""
    llm.reset()
    llm.script(["I would describe the camera motion.", SHAPE_ERROR_REPLY], model="coder")
    llm.script([ANSWER_REPLY], model="answerer")
    events, result = solve_streamed(
        stack.model_agent, question=MOTION_QUESTION, scene_id=stack.scene_id, max_repairs=1
    )
    model_starts = [e for e in events if e[:2] == ("program", "started") and "offline planner" not in e[2]]
    assert len(model_starts) == 1
    # The model's attempts ran out: the planner's program (labelled) gave the clue the answerer read.
    assert ("program", "done", "attempt 2 written by the offline planner (fallback)") in events
    assert events[-2:] == [
        ("answer", "started", "answering with answerer" + MOTION_READ),
        ("answer", "done", "B"),
    ]
    assert result.program_source == "planner"
    assert replayed(result) == events


def test_the_response_json_carries_the_records_but_not_the_images(stack):
    body = {"question": MOTION_QUESTION, "scene_id": stack.scene_id}
    response = httpx.post(stack.offline_agent.url + "/v1/solve", json=body, timeout=120)
    assert response.status_code == 200, response.text
    steps = response.json()["steps"]
    assert [step["kind"] for step in steps] == ["scene", "reconstruction", "program", "execution", "answer"]
    assert [step["stage"] for step in steps] == ["upload", "reconstruction", "program", "execution", "answer"]
    for name in ("input_pngs", "clue_pngs", "summary"):
        assert all(name not in step for step in steps)
    assert "text" not in response.json()["intent"]  # the question the client sent is not echoed


# ---- the log and its callbacks, without services -------------------------------------------------


def test_a_step_that_raises_is_aborted_and_its_end_is_no_stage_event():
    events: list[tuple[str, str, str]] = []
    log = SolveLog()
    StageReporter(lambda *event: events.append(event)).watch(log.callbacks)
    seen: list[tuple[str, str]] = []
    log.callbacks.register(schemas.StepRecord, lambda step, moment: seen.append((step.kind, moment)))
    with log.record(schemas.SceneStep(uploaded_images=2)) as scene:
        scene.scene_id = "a" * 24
    with pytest.raises(RuntimeError), log.record(schemas.ReconstructionStep()):
        raise RuntimeError("recon went away")
    assert events == [
        ("upload", "started", "2 images"),
        ("upload", "done", f"scene {'a' * 24}"),
        ("reconstruction", "started", "service default backbone"),  # and no end: the error event says it
    ]
    assert seen == [
        ("scene", "started"),
        ("scene", "finished"),
        ("reconstruction", "started"),
        ("reconstruction", "aborted"),
    ]
    aborted = log.steps[-1]
    assert aborted.error == "RuntimeError: recon went away" and aborted.duration_ms >= 0
    assert log.of(schemas.SceneStep) == [log.steps[0]]
