"""Programs run in the sandbox for one solve, one ExecutionStep each; typed-in output is no evidence.

`SandboxRuns.execute` is what codegen's repair loop and the offline planner hand a program to. A
recon failure while the program ran ends the solve (InfrastructureFailure: 502/503/504 with the
attempts so far): the service failed, not the program, and no repair can help.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field

import numpy as np

from services.agent.clue_check import clue_problem
from services.agent.codegen import ExecutionOutcome
from services.agent.evidence import typed_in_lines
from services.agent.infrastructure import FailureRecordingClient, InfrastructureFailure, gateway_status
from services.agent.recon_tools import ReconToolProvider
from services.agent.sandbox import SandboxLimits, run_program
from services.agent.sandbox.jail import JailStatus
from services.agent.sandbox_budget import CpuBudget, SandboxGate
from services.agent.steps import SolveLog
from shared.questions.intent import QuestionIntent
from shared.wire.schemas import AttemptRecord, ExecutionStep, ProgramStep


def not_evidence_error(clue_text: str, notes: list[str]) -> str:
    """The repair message for a program whose whole output it typed in itself."""
    return (
        f"the program returned text it typed in itself ({clue_text.strip()[:160]!r}), which is not "
        "evidence: " + " ".join(notes[:2])
    )


@dataclass
class SandboxRuns:
    """Everything a run needs besides the program, and the attempts so far (for a failure report)."""

    log: SolveLog
    intent: QuestionIntent
    num_images: int
    tools: ReconToolProvider
    recon: FailureRecordingClient  # the recon client the tools call, recording a service failure
    limits: SandboxLimits
    jail: JailStatus
    python_checks: bool
    gate: SandboxGate | None = None  # the agent's cap on running sandboxes
    cpu_budget: CpuBudget | None = None  # this solve's CPU across its attempts
    answerer_reads_images: bool = True  # False: no vision answer model, an image-only clue is unread
    answer_model: bool = True  # False: the offline answerer chooses, and it reads motion sentences only
    attempts_so_far: list[AttemptRecord] = field(default_factory=list)

    def execute(self, source: str, written_by_model: bool = True) -> ExecutionOutcome:
        programs = self.log.of(ProgramStep)
        step = ExecutionStep(
            run=len(self.log.of(ExecutionStep)) + 1, attempt=programs[-1].attempt if programs else 1
        )
        with self.log.record(step):
            self._run(step, source, written_by_model)
        return ExecutionOutcome(step.ok, step.error, step, step.error_kind)

    def _run(self, step: ExecutionStep, source: str, written_by_model: bool) -> None:
        started = time.perf_counter()
        spent = self.cpu_budget.spent_error() if self.cpu_budget else None
        if spent is not None:  # no run at all: the repair loop shows the model why
            self.attempts_so_far.append(AttemptRecord(program=source, error=spent, latency_ms=0.0))
            step.ok, step.error, step.error_kind = False, spent, "cpu_budget"
            return
        limits = self.cpu_budget.limits_for_next_run(self.limits) if self.cpu_budget else self.limits
        with self.gate.slot() if self.gate else contextlib.nullcontext():
            result = run_program(
                source,
                self.intent.text,
                self.num_images,
                self.tools,
                limits,
                jail_status=self.jail,
                python_checks=self.python_checks,
                cancel=self.log.cancellation,
            )
        if self.cpu_budget is not None:
            self.cpu_budget.charge(result.cpu_seconds)
        latency_ms = round((time.perf_counter() - started) * 1e3, 2)
        self.attempts_so_far.append(AttemptRecord(program=source, error=result.error, latency_ms=latency_ms))
        if self.recon.failure is not None:  # the service failed, not the program: no repair can help
            raise InfrastructureFailure(
                gateway_status(self.recon.failure),
                f"the reconstruction service failed while the program ran: {self.recon.failure}",
                self.attempts_so_far,
            )
        step.ok, step.error, step.error_kind = result.ok, result.error, result.error_kind
        step.clue_text, step.clue_pngs, step.clue_images = (
            result.clue_text,
            result.clue_images,
            len(result.clue_images),
        )
        if result.ok and written_by_model and result.clue_text and not result.clue_images:
            kept, typed = typed_in_lines(result.clue_text, source, self.intent)
            if kept is None:  # all it returned is its own words: ask for tool output instead
                step.ok, step.error_kind = False, "not_evidence"
                step.error = not_evidence_error(result.clue_text, typed)
        if step.ok:
            self._check_clue(step, written_by_model)

    def _check_clue(self, step: ExecutionStep, written_by_model: bool) -> None:
        """The asked-view check: a clue about other views than the question's is sent back."""
        rendered = [
            np.asarray(self.tools.rendered_poses[png][0], dtype=float)
            for png in step.clue_pngs
            if png in self.tools.rendered_poses
        ]
        views = [np.asarray(pose, dtype=float) for pose in self.tools.view_extrinsics]
        # An image-only clue nothing can read sends the model's program back; the planner's program
        # is what it is (its answer is null with the reason).
        reads_images = self.answerer_reads_images or not written_by_model
        problem = clue_problem(
            self.intent, step.clue_text, rendered, step.clue_images, views, reads_images, self.answer_model
        )
        if problem is not None:
            step.ok, step.error_kind = False, problem.kind
            step.error = f"{problem.message}; {problem.fix}"


__all__ = ["SandboxRuns", "not_evidence_error"]
