"""One /v1/solve: scene → program (model or offline planner) → sandboxed run (repaired) → answer.

`SolvePipeline.solve` runs the stages of services/agent/stages/ in the order of the paper's Figure 2.
Each stage fills a typed step record (shared.wire.schemas: SceneStep, ReconstructionStep,
ProgramStep, ExecutionStep, AnswerStep) inside the solve's `SolveLog`; the stage events of the
event stream come from the records through the log's callbacks (services/agent/progress.py), and
the response is made from them (services/agent/response.py).
"""

from __future__ import annotations

import time

from services.agent import cancellation as solve_cancellation
from services.agent.cancellation import Cancellation
from services.agent.errors import SolveError
from services.agent.infrastructure import FailureRecordingClient
from services.agent.llm import ChatClient, ChatModelConfig
from services.agent.progress import ProgressCallback, StageReporter
from services.agent.recon_tools import ReconToolProvider
from services.agent.response import respond
from services.agent.sandbox import SandboxLimits
from services.agent.sandbox.jail import JailMode, JailStatus, probe
from services.agent.sandbox_budget import CpuBudget, SandboxGate
from services.agent.stages.answer import OFFLINE_ANSWERER, Answerers, from_clue, from_photos
from services.agent.stages.clue import read_clue
from services.agent.stages.execution import SandboxRuns
from services.agent.stages.program import OFFLINE_PLANNER, WrittenProgram, write_and_run
from services.agent.stages.scene import reconstruct, upload
from services.agent.steps import SolveLog
from shared.questions.intent import QuestionIntent, parse_question
from shared.wire.access import DEFAULT_TENANT
from shared.wire.client import ReconClient, RetryPolicy
from shared.wire.schemas import AnswerStep, ReconstructionStep, SceneStep, SolveResponse
from shared.wire.settings import AgentSettings


def _model_config(settings: AgentSettings, role: str) -> ChatModelConfig | None:
    """The chat model of `role` ("code" or "answer") from PYSPATIAL_<ROLE>_MODEL_* settings."""
    model = getattr(settings, f"{role}_model")
    if not model:
        return None
    return ChatModelConfig(
        base_url=getattr(settings, f"{role}_model_base_url") or "https://api.openai.com/v1",
        model=model,
        api_key=getattr(settings, f"{role}_model_api_key"),
        timeout_s=settings.model_timeout_s,
        max_retries=settings.model_max_retries,
        max_tokens=getattr(settings, f"{role}_model_max_tokens"),
        text_only=getattr(settings, f"{role}_model_text_only"),
        text_only_hint=f"set PYSPATIAL_{role.upper()}_MODEL_TEXT_ONLY=true",
        key_setting=f"PYSPATIAL_{role.upper()}_MODEL_API_KEY",
    )


class SolvePipeline:
    def __init__(self, settings: AgentSettings) -> None:
        self.settings = settings
        recon_key = settings.recon_api_key.get_secret_value() if settings.recon_api_key else None
        # Recon calls are idempotent: retried with backoff on a reset or a 502/503, within a window.
        retry = RetryPolicy(attempts=settings.recon_attempts, window_s=settings.recon_retry_window_s)
        # Private: every route reaches recon through `recon_for(tenant)` (routes/dependencies.py),
        # so no request can read another tenant's scenes through a client that names none.
        self._recon = ReconClient(
            settings.recon_url, timeout=settings.recon_timeout_s, api_key=recon_key, retry=retry
        )
        code = _model_config(settings, "code")
        answer = _model_config(settings, "answer")
        self.code_client = ChatClient(code) if code else None
        self.answer_client = ChatClient(answer) if answer else None
        self.answerers = Answerers(self.answer_client, settings.answer_model_text_only, self.code_client)
        self.limits = SandboxLimits(
            cpu_seconds=settings.sandbox_cpu_s,
            wall_seconds=settings.sandbox_wall_s,
            memory_mb=settings.sandbox_memory_mb,
            max_tool_calls=settings.sandbox_max_tool_calls,
        )
        self.sandbox_gate = SandboxGate(
            settings.sandbox_max_running, settings.sandbox_max_waiting, settings.sandbox_retry_after_s
        )
        self._jail: JailStatus | None = None

    @property
    def jail(self) -> JailStatus:
        """The OS jail of the program sandbox, probed once (a real program run, ~0.1 s)."""
        if self._jail is None:
            self._jail = probe(JailMode(self.settings.sandbox_jail))
            if self.settings.sandbox_test_only_unchecked and not self._jail.jailed:
                raise RuntimeError("PYSPATIAL_SANDBOX_TEST_ONLY_UNCHECKED needs an active OS jail")
        return self._jail

    @property
    def code_model_name(self) -> str:
        return self.settings.code_model or OFFLINE_PLANNER

    @property
    def answer_model_name(self) -> str:
        return self.settings.answer_model or OFFLINE_ANSWERER

    def recon_for(self, tenant: str) -> ReconClient:
        """The recon client acting for `tenant`: recon serves that tenant's scenes only."""
        return self._recon.for_tenant(tenant)

    def readiness_probe(self) -> ReconClient:
        """The client that names no tenant, for `/readyz` alone (recon's `/readyz` and `/v1/backbones`,
        which read no scene)."""
        return self._recon

    def close(self) -> None:
        self._recon.close()
        for client in (self.code_client, self.answer_client):
            if client is not None:
                client.close()

    def solve(
        self,
        question: str,
        image_files: list[bytes] | None,
        scene_id: str | None,
        backbone: str | None,
        max_repairs: int | None,
        progress: ProgressCallback | None = None,
        cancellation: Cancellation | None = None,
        tenant: str = DEFAULT_TENANT,
    ) -> SolveResponse:
        """Figure 2 of the paper: scene → reconstruction → program, run and repaired → answer.

        `cancellation` (the client went away) stops the work: SolveCancelled is raised. Every call
        to recon names `tenant` (the caller's), so the solve sees that tenant's scenes only.
        """
        log = SolveLog(cancellation=cancellation)
        if progress is not None:
            StageReporter(progress).watch(log.callbacks)
        with solve_cancellation.bound(log.cancellation):  # the model clients abandon their calls
            # The solve's deadline bounds its recon calls and their retries, not only each window.
            deadline = time.monotonic() + self.settings.solve_deadline_s
            recon = self.recon_for(tenant).until(deadline)
            return self._solve(log, recon, question, image_files, (scene_id, backbone, max_repairs))

    def _solve(
        self,
        log: SolveLog,
        recon_client: ReconClient,
        question: str,
        image_files: list[bytes] | None,
        options: tuple[str | None, str | None, int | None],
    ) -> SolveResponse:
        scene_id, backbone, max_repairs = options
        self._check_ready(backbone)
        with log.record(SceneStep(uploaded_images=len(image_files or []), scene_id=scene_id)) as scene:
            upload(scene, image_files, recon_client, self.settings)
        intent = parse_question(question, scene.num_images)  # parsed once: every stage takes the intent
        _check_views(intent, scene.num_images)
        with log.record(ReconstructionStep(requested_backbone=backbone)) as recon:
            reconstruct(recon, scene.scene_id, recon_client)
        if recon.error is not None:  # the backbone cannot use these photos: answer from them alone
            return self._from_photos(
                log, intent, scene, recon, WrittenProgram(self.code_model_name), recon.error
            )
        runs = self._sandbox_runs(log, recon_client, intent, scene, backbone)
        written = write_and_run(runs, scene.input_pngs, self.code_client, self.settings, max_repairs)
        if written.run is None and self.answer_client is not None:
            why = f"no program ran successfully: {written.failure}"
            return self._from_photos(log, intent, scene, recon, written, why)
        reading = read_clue(written, intent, runs.tools, recon.cameras)
        with log.record(AnswerStep(answerer=self.answer_model_name, reading=read_as(intent))) as answer:
            from_clue(answer, self.answerers, intent, scene.input_pngs, written, reading)
        return respond(log, intent, scene, recon, written, answer, reading)

    def _from_photos(
        self,
        log: SolveLog,
        intent: QuestionIntent,
        scene: SceneStep,
        recon: ReconstructionStep,
        written: WrittenProgram,
        why: str,
    ) -> SolveResponse:
        """No program ran: the answer model answers from the photos alone (as the paper's code does),
        and the response says so; without an answer model the answer is null with the reason."""
        asked = self.answer_model_name if self.answer_client is not None else None
        with log.record(AnswerStep(answerer=asked, from_photos=True, reading=read_as(intent))) as answer:
            from_photos(answer, self.answerers, intent, scene.input_pngs, why)
        return respond(log, intent, scene, recon, written, answer, fallback_reason=why)

    def _check_ready(self, backbone: str | None) -> None:
        """An unknown backbone is bad input (422), a known one that cannot run here is a 409 that
        says what to run; a sandbox that cannot run programs is a 503."""
        if backbone is not None:
            menu = self._recon.backbones()
            available = menu["available"]
            if backbone not in available:
                reasons = {entry["name"]: entry.get("reason") for entry in menu.get("backbones", [])}
                if reasons.get(backbone):
                    raise SolveError(409, f"backbone {backbone} is not available here: {reasons[backbone]}")
                raise SolveError(422, f"unknown backbone {backbone!r}; available: {', '.join(available)}")
        if not self.jail.runs_programs:
            raise SolveError(503, f"the program sandbox is unavailable: {self.jail.detail}")

    def _sandbox_runs(
        self,
        log: SolveLog,
        recon_client: ReconClient,
        intent: QuestionIntent,
        scene: SceneStep,
        backbone: str | None,
    ) -> SandboxRuns:
        """How this solve's programs run: its own recon client (recording failures) behind the tools."""
        recon_of_this_solve = FailureRecordingClient(recon_client)
        scene_id = scene.scene_id or ""
        tools = ReconToolProvider(recon_of_this_solve, scene_id, backbone, scene.input_pngs)
        return SandboxRuns(
            log,
            intent,
            scene.num_images,
            tools,
            recon_of_this_solve,
            self.limits,
            self.jail,
            python_checks=not self.settings.sandbox_test_only_unchecked,
            gate=self.sandbox_gate,
            cpu_budget=CpuBudget(self.settings.sandbox_solve_cpu_s),
            answerer_reads_images=self.answer_client is not None and not self.settings.answer_model_text_only,
            answer_model=self.answer_client is not None,
        )


def read_as(intent: QuestionIntent) -> str | None:
    """The reading's summary of a camera question, for the answer step and its stage event."""
    reading = intent.reading
    return reading.summary if reading is not None and reading.is_camera else None


def _check_views(intent: QuestionIntent, num_images: int) -> None:
    """A question naming a view that does not exist is bad input (422), whoever writes the program."""
    for view in [*intent.mentioned_views, *([intent.asked_view] if intent.asked_view else [])]:
        if not 1 <= view <= num_images:
            raise SolveError(
                422,
                f"cannot plan a program for this question: the question names view {view}, "
                f"but there are {num_images} image(s)",
            )


__all__ = ["SolveError", "SolvePipeline"]
