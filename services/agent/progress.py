"""The stage events of a solve (`stage`, `state`, `detail`), made from its step records as they come.

`StageReporter.watch(callbacks)` registers one callback per record type; each turns a step starting
or ending into the events the page and the CLI show (services/agent/solve_stream.py sends them as
SSE). The program stage opens once and stays open while a code model is asked again after a reply
without a program; it closes when a program goes to the sandbox (or the planner has none), and a
repair opens it again. A step that raised sends nothing: the error event that follows says what failed.
"""

from __future__ import annotations

from collections.abc import Callable

from services.agent.steps import Moment, StepCallbacks
from shared.wire.schemas import (
    AnswerStep,
    ExecutionStep,
    ProgramStep,
    ReconstructionStep,
    SceneStep,
    StepRecord,
)

# progress(stage, state, detail): stage in shared.wire.schemas.SolveStage, state started | done | failed.
ProgressCallback = Callable[[str, str, str], None]


class StageReporter:
    """The stage events of one solve; `watch` hooks it to the solve's callbacks."""

    def __init__(self, progress: ProgressCallback) -> None:
        self.progress = progress
        self.runs = 0  # sandbox runs so far: "attempt N" in the events counts runs
        self.program_open = False

    def watch(self, callbacks: StepCallbacks) -> None:
        handlers: dict[type[StepRecord], Callable] = {
            SceneStep: self.scene,
            ReconstructionStep: self.reconstruction,
            ProgramStep: self.program,
            ExecutionStep: self.execution,
            AnswerStep: self.answer,
        }
        for step_type, handler in handlers.items():
            callbacks.register(step_type, handler)

    def scene(self, step: SceneStep, moment: Moment) -> None:
        if moment == "started":
            given = f"{step.uploaded_images} images" if step.uploaded_images else f"scene {step.scene_id}"
            self.progress("upload", "started", given)
        elif moment == "finished":
            self.progress("upload", "done", f"scene {step.scene_id}")

    def reconstruction(self, step: ReconstructionStep, moment: Moment) -> None:
        if moment == "started":
            self.progress("reconstruction", "started", step.requested_backbone or "service default backbone")
        elif moment == "finished" and step.error is not None:
            self.progress("reconstruction", "failed", step.error)
        elif moment == "finished":
            cached = " (cached)" if step.cached else ""
            placed = f"{step.views_placed} of {step.num_views} views placed"
            self.progress(
                "reconstruction", "done", f"{step.backbone}: {placed}, {step.num_points} points{cached}"
            )

    def program(self, step: ProgramStep, moment: Moment) -> None:
        if step.fallback and moment == "started":  # never presented as the model's program
            self.program_open = True
            self.progress("program", "started", "the code model's attempts failed: offline planner")
        elif step.fallback and moment == "finished" and step.program is not None:
            self.program_open = False
            written = f"attempt {self.runs + 1} written by the offline planner (fallback)"
            self.progress("program", "done", written)
        elif moment == "started" and not self.program_open:
            self.program_open = True
            if step.repairs is None:
                self.progress("program", "started", f"writing a program with {step.author}")
            else:
                self.progress("program", "started", f"asking {step.author} to repair attempt {step.repairs}")
        elif moment == "finished" and step.program is not None:
            self.program_open = False
            self.progress("program", "done", f"attempt {self.runs + 1} written")
        elif moment == "finished" and step.error_kind == "unplannable":
            self.program_open = False
            self.progress("program", "failed", step.error or "")

    def execution(self, step: ExecutionStep, moment: Moment) -> None:
        if moment == "started":
            self.runs = step.run
            self.progress("execution", "started", f"running attempt {step.run} in the sandbox")
        elif moment == "finished":
            self.progress(
                "execution", "done" if step.ok else "failed", step.error or f"attempt {step.run} ran"
            )

    def answer(self, step: AnswerStep, moment: Moment) -> None:
        if moment == "started" and step.answerer is not None:
            source = "from the photos alone " if step.from_photos else ""
            read = f" ({step.reading})" if step.reading else ""
            self.progress("answer", "started", f"answering {source}with {step.answerer}{read}")
        elif moment == "finished":
            self.progress("answer", "done" if step.answer else "failed", step.answer or step.error or "")


__all__ = ["ProgressCallback", "StageReporter"]
