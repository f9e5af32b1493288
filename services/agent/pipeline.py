"""One /v1/solve: scene → program (model or offline planner) → sandboxed run → answer."""

from __future__ import annotations

import base64
import io
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from PIL import Image

from services.agent.answering import (
    VISION_MODEL_HINT,
    AnswerResult,
    answer_from_images,
    answer_offline,
    answer_text_clue_with_model,
    answer_with_model,
)
from services.agent.clue_views import clue_views
from services.agent.codegen import ExecutionOutcome, generate_program
from services.agent.evidence import typed_in_lines
from services.agent.infrastructure import FailureRecordingClient, InfrastructureFailure, gateway_status
from services.agent.llm import ChatClient, ChatModelConfig, ModelConfigurationError
from services.agent.planner import PlanningError, UnplannableQuestion, plan_intent
from services.agent.recon_tools import ReconToolProvider
from services.agent.sandbox import ExecutionResult, SandboxLimits, run_program
from services.agent.sandbox.jail import JailMode, JailStatus, probe
from services.agent.sandbox.text import clean_text
from shared.imaging.codecs import decode_image, encode_image
from shared.questions.intent import QuestionIntent, parse_question
from shared.wire.client import ReconClient, ServiceError
from shared.wire.schemas import AttemptRecord, Clue, SolveResponse, SolveTimings, TokenCounts
from shared.wire.settings import AgentSettings

log = logging.getLogger("pyspatial.agent")

OFFLINE_PLANNER = "offline-planner"
OFFLINE_ANSWERER = "offline-answerer"
# progress(stage, state, detail): stage in shared.wire.schemas.SolveStage, state started | done | failed.
ProgressCallback = Callable[[str, str, str], None]
ANSWER_IMAGE_SIDE = 1024  # images shown to the answer model are downscaled to this longest side


EMPTY_VIEW_COVERAGE = 0.05  # a rendered view with less of its area drawn than this "shows nothing"


def coverage_notes(clue_images: list[bytes]) -> list[str]:
    """Say which rendered views are (nearly) empty.

    Novel views are rendered on white; where the reconstruction has no points (a direction no
    input photo looked at) the view stays blank. Saying so keeps an answer model from reading
    meaning into an empty picture.
    """
    notes = []
    for index, png in enumerate(clue_images, start=1):
        rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
        drawn = float(np.mean(np.any(rgb != 255, axis=2)))
        if drawn < EMPTY_VIEW_COVERAGE:
            notes.append(
                f"Rendered view {index} shows almost nothing ({drawn:.0%} of it drawn): that direction "
                "was not seen in the input images, so the reconstruction has no points there."
            )
    return notes


IMAGES_ONLY = "images_only"


class SolveError(Exception):
    """A request cannot be solved for a reason the client should see (status + message)."""

    def __init__(self, status_code: int, message: str) -> None:
        super().__init__(message)
        self.status_code = status_code
        self.message = message


@dataclass
class _Stage:
    """Accumulates wall time of the sandbox runs inside the self-repair loop."""

    execution_s: float = 0.0
    last: ExecutionResult | None = None
    runs: list[ExecutionResult] = field(default_factory=list)


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
    )


def not_evidence_error(clue_text: str, notes: list[str]) -> str:
    """The repair message for a program whose whole output it typed in itself."""
    return (
        f"the program returned text it typed in itself ({clue_text.strip()[:160]!r}), which is not "
        "evidence: " + " ".join(notes[:2])
    )


class SolvePipeline:
    def __init__(self, settings: AgentSettings) -> None:
        self.settings = settings
        recon_key = settings.recon_api_key.get_secret_value() if settings.recon_api_key else None
        self.recon = ReconClient(settings.recon_url, timeout=settings.recon_timeout_s, api_key=recon_key)
        code = _model_config(settings, "code")
        answer = _model_config(settings, "answer")
        self.code_client = ChatClient(code) if code else None
        self.answer_client = ChatClient(answer) if answer else None
        self.limits = SandboxLimits(
            cpu_seconds=settings.sandbox_cpu_s,
            wall_seconds=settings.sandbox_wall_s,
            memory_mb=settings.sandbox_memory_mb,
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

    def close(self) -> None:
        self.recon.close()
        for client in (self.code_client, self.answer_client):
            if client is not None:
                client.close()

    # ---- the stages ------------------------------------------------------------------------

    def solve(
        self,
        question: str,
        image_files: list[bytes] | None,
        scene_id: str | None,
        backbone: str | None,
        max_repairs: int | None,
        progress: ProgressCallback | None = None,
    ) -> SolveResponse:
        started = time.perf_counter()
        report = progress or (lambda stage, state, detail="": None)
        if backbone is not None:
            available = self.recon.backbones()["available"]
            if backbone not in available:
                raise SolveError(422, f"unknown backbone {backbone!r}; available: {', '.join(available)}")
        if not self.jail.runs_programs:
            raise SolveError(503, f"the program sandbox is unavailable: {self.jail.detail}")
        report("upload", "started", f"{len(image_files)} images" if image_files else f"scene {scene_id}")
        scene_id, input_pngs = self._scene(image_files, scene_id)
        report("upload", "done", f"scene {scene_id}")
        # The question is parsed once; the planner, the prompts and the answerers take the result.
        intent = parse_question(question, len(input_pngs))
        self._check_views(intent, len(input_pngs))
        report("reconstruction", "started", backbone or "service default backbone")
        # Reconstruct first: the program's own reconstruct() is then a cache hit. Input the backbone
        # cannot use (a 422) leaves the photos: answered from them alone when an answer model is set.
        reconstruct_started = time.perf_counter()
        try:
            summary = self.recon.reconstruct(scene_id, backbone)
        except ServiceError as error:
            if error.status_code != 422:
                raise
            used = backbone or self.recon.backbones().get("default", "default")
            why = f"the {used} backbone could not reconstruct the scene: {error.message}"
            report("reconstruction", "failed", why)
            return self._images_only(
                question,
                input_pngs,
                scene_id,
                used,
                intent,
                why,
                started,
                reconstruction_ms=(time.perf_counter() - reconstruct_started) * 1e3,
                report=report,
            )
        reconstruction_ms = (time.perf_counter() - reconstruct_started) * 1e3
        registered = sum(camera.registered for camera in summary.cameras)
        report(
            "reconstruction",
            "done",
            f"{summary.backbone}: {registered} of {len(summary.cameras)} views placed, "
            f"{summary.num_points} points{' (cached)' if summary.cached else ''}",
        )
        recon_of_this_solve = FailureRecordingClient(self.recon)
        tools = ReconToolProvider(recon_of_this_solve, scene_id, backbone, input_pngs)
        stage = _Stage()
        attempts_so_far: list[AttemptRecord] = []

        def execute(source: str, written_by_model: bool = True) -> ExecutionOutcome:
            attempt = len(stage.runs) + 1
            report("program", "done", f"attempt {attempt} written")
            report("execution", "started", f"running attempt {attempt} in the sandbox")
            run_started = time.perf_counter()
            result = run_program(
                source,
                question,
                len(input_pngs),
                tools,
                self.limits,
                jail_status=self.jail,
                python_checks=not self.settings.sandbox_test_only_unchecked,
            )
            stage.execution_s += time.perf_counter() - run_started
            stage.last = result
            stage.runs.append(result)
            latency_ms = round((time.perf_counter() - run_started) * 1e3, 2)
            attempts_so_far.append(AttemptRecord(program=source, error=result.error, latency_ms=latency_ms))
            failure = recon_of_this_solve.failure
            if failure is not None:  # the service failed, not the program: no repair can help
                raise InfrastructureFailure(
                    gateway_status(failure),
                    f"the reconstruction service failed while the program ran: {failure}",
                    attempts_so_far,
                )
            outcome = ExecutionOutcome(
                ok=result.ok, error=result.error, payload=result, error_kind=result.error_kind
            )
            if result.ok and written_by_model and result.clue_text and not result.clue_images:
                kept, typed = typed_in_lines(result.clue_text, source, question)
                if kept is None:  # all it returned is its own words: ask for tool output instead
                    outcome = ExecutionOutcome(
                        False, not_evidence_error(result.clue_text, typed), result, "not_evidence"
                    )
            report("execution", "done" if outcome.ok else "failed", outcome.error or f"attempt {attempt} ran")
            repairs = self.settings.max_repairs if max_repairs is None else max_repairs
            if not outcome.ok and self.code_client is not None and attempt <= repairs:
                report("program", "started", f"asking {self.code_model_name} to repair attempt {attempt}")
            return outcome

        report("program", "started", f"writing a program with {self.code_model_name}")
        codegen_started = time.perf_counter()
        attempts, program, code_model, unplannable, fallback = self._generate(
            question, intent, input_pngs, execute, max_repairs
        )
        codegen_ms = (time.perf_counter() - codegen_started - stage.execution_s) * 1e3
        if unplannable:
            report("program", "failed", unplannable)

        result = stage.last if program is not None else None
        if result is None or not result.ok:
            failure = unplannable or (attempts[-1].error if attempts else "no program was produced")
            if self.answer_client is not None:
                return self._images_only(
                    question,
                    input_pngs,
                    scene_id,
                    summary.backbone,
                    intent,
                    f"no program ran successfully: {failure}",
                    started,
                    reconstruction_ms=reconstruction_ms,
                    codegen_ms=codegen_ms,
                    execution_ms=stage.execution_s * 1e3,
                    attempts=attempts,
                    code_model=code_model,
                    code_model_fallback=fallback,
                    report=report,
                )
        notes = coverage_notes(result.clue_images) if result is not None and result.ok else []
        clue_text = result.clue_text if result is not None else None
        if result is not None and result.ok and fallback is None and self.code_client is not None:
            clue_text, typed = typed_in_lines(clue_text, program, question)  # evidence, not assertions
            notes = [*notes, *typed]
        answer_started = time.perf_counter()
        report("answer", "started", f"answering with {self.answer_model_name}")
        if result is None or not result.ok:
            answer = AnswerResult(
                answer=None,
                reasoning="",
                raw=None,
                method="none",
                reason=f"no program ran successfully: {failure}; answering from the photos alone needs an "
                "answer model (PYSPATIAL_ANSWER_MODEL)",
            )
            answer_model = self.answer_model_name
        else:
            answer, answer_model = self._answer(
                question,
                intent,
                input_pngs,
                program,
                result,
                clue_text,
                notes,
                code_model_failed=fallback is not None,
            )
        answering_ms = (time.perf_counter() - answer_started) * 1e3
        report("answer", "done" if answer.answer else "failed", answer.answer or answer.reason or "")

        clue = Clue()
        if result is not None and result.ok:
            clue = Clue(
                text=result.clue_text,
                images=[base64.b64encode(png).decode("ascii") for png in result.clue_images],
                views=clue_views(result.clue_images, tools, summary),
                notes=notes,
            )
        return SolveResponse(
            answer=answer.answer,
            answer_reason=answer.reason if answer.answer is None else None,
            reasoning=answer.reasoning,
            program=program,
            clue=clue,
            attempts=attempts,
            scene_id=scene_id,
            backbone=summary.backbone,
            code_model=code_model,
            code_model_fallback=fallback,
            answer_model=answer_model,
            answer_method=answer.method if answer.answer is not None else None,
            tokens=TokenCounts(
                code_prompt=sum(a.prompt_tokens or 0 for a in attempts),
                code_completion=sum(a.completion_tokens or 0 for a in attempts),
                answer_prompt=answer.prompt_tokens,
                answer_completion=answer.completion_tokens,
            ),
            intent=intent,
            timings=SolveTimings(
                reconstruction_ms=round(reconstruction_ms, 2),
                codegen_ms=round(codegen_ms, 2),
                execution_ms=round(stage.execution_s * 1e3, 2),
                answering_ms=round(answering_ms, 2),
                total_ms=round((time.perf_counter() - started) * 1e3, 2),
            ),
        )

    def _answer(
        self,
        question: str,
        intent: QuestionIntent,
        input_pngs: list[bytes],
        program: str,
        result: ExecutionResult,
        clue_text: str | None,
        notes: list[str],
        code_model_failed: bool = False,
    ) -> tuple[AnswerResult, str]:
        """The answer to a clue that ran, and the name of what gave it (vision model, text model, offline)."""
        client, text_only = self.answer_client, self.settings.answer_model_text_only
        if client is not None and not text_only:
            full_text = "\n".join(filter(None, [clue_text, *notes])) or None
            answer = answer_with_model(client, question, input_pngs, program, full_text, result.clue_images)
            return answer, self.answer_model_name
        if client is not None:  # a text-only answer model: it reads text clues and nothing else
            if clue_text:
                answer = answer_text_clue_with_model(client, question, program, clue_text)
                return answer, f"{self.answer_model_name} (text only)"
            count = len(result.clue_images)
            reason = (
                f"the answer model {self.answer_model_name!r} is text-only and the clue is {count} rendered "
                f"view(s): {VISION_MODEL_HINT}"
            )
            return AnswerResult(answer=None, method="none", reason=reason), self.answer_model_name
        offline = answer_offline(question, clue_text, result.clue_images, intent)
        if offline.answer is not None or not clue_text or self.code_client is None or code_model_failed:
            return offline, OFFLINE_ANSWERER
        # Only a (text) code model is configured and the offline rules could not read the text clue.
        answer = answer_text_clue_with_model(self.code_client, question, program, clue_text)
        if answer.answer is None:
            reason = (
                f"{offline.reason}; the text model {self.code_model_name!r} gave none either: {answer.reason}"
            )
            return answer.model_copy(update={"reason": reason}), OFFLINE_ANSWERER
        return answer, f"{self.code_model_name} (text only)"

    def _scene(self, image_files: list[bytes] | None, scene_id: str | None) -> tuple[str, list[bytes]]:
        """Upload the images (or look up the scene) and prepare PNGs for the models."""
        if image_files and scene_id:
            raise SolveError(422, "send either images or a scene_id, not both")
        if image_files:
            if len(image_files) > self.settings.max_images:
                raise SolveError(422, f"{len(image_files)} images; at most {self.settings.max_images}")
            # Decode first: an unreadable image is reported by its number (1-based, as on the page).
            input_pngs = [self._model_png(blob, i) for i, blob in enumerate(image_files)]
            return self.recon.upload_scene(image_files).scene_id, input_pngs
        elif scene_id:
            info = self.recon.scene_info(scene_id)
            image_files = [self.recon.scene_image(scene_id, i) for i in range(info.num_images)]
        else:
            raise SolveError(422, "send images (multipart 'images' or JSON base64) or an existing scene_id")
        return scene_id, [self._model_png(blob, i) for i, blob in enumerate(image_files)]

    def _model_png(self, blob: bytes, index: int) -> bytes:
        rgb = decode_image(
            blob, max_bytes=self.settings.max_image_bytes, max_pixels=10**9, label=f"image {index + 1}"
        )
        height, width = rgb.shape[:2]
        scale = ANSWER_IMAGE_SIDE / max(height, width)
        if scale < 1:
            size = (max(1, round(width * scale)), max(1, round(height * scale)))
            rgb = np.asarray(Image.fromarray(rgb).resize(size, Image.Resampling.LANCZOS))
        return encode_image(rgb, "png")

    def _images_only(
        self,
        question: str,
        input_pngs: list[bytes],
        scene_id: str,
        backbone: str,
        intent: QuestionIntent,
        why: str,
        started: float,
        reconstruction_ms: float = 0.0,
        codegen_ms: float = 0.0,
        execution_ms: float = 0.0,
        attempts: list[AttemptRecord] | None = None,
        code_model: str | None = None,
        code_model_fallback: str | None = None,
        report: ProgressCallback | None = None,
    ) -> SolveResponse:
        """No program ran: the answer model answers from the photos alone (as the paper's code does),
        and the response says so; without an answer model the answer is null with the reason."""
        report = report or (lambda stage, state, detail="": None)
        answer_started = time.perf_counter()
        if self.answer_client is not None:
            report("answer", "started", f"answering from the photos alone with {self.answer_model_name}")
            answer = answer_from_images(self.answer_client, question, input_pngs)
            fallback = IMAGES_ONLY
        else:
            answer = AnswerResult(
                answer=None,
                method="none",
                reason=f"{why}; answering from the photos alone needs an answer model "
                "(PYSPATIAL_ANSWER_MODEL)",
            )
            fallback = None
        answering_ms = (time.perf_counter() - answer_started) * 1e3
        report("answer", "done" if answer.answer else "failed", answer.answer or answer.reason or "")
        return SolveResponse(
            answer=answer.answer,
            answer_reason=answer.reason if answer.answer is None else None,
            reasoning=answer.reasoning,
            program=None,
            clue=Clue(),
            attempts=attempts or [],
            scene_id=scene_id,
            backbone=backbone,
            code_model=code_model or self.code_model_name,
            code_model_fallback=code_model_fallback,
            answer_model=self.answer_model_name,
            answer_method=answer.method if answer.answer is not None else None,
            fallback=fallback,
            fallback_reason=why,
            intent=intent,
            timings=SolveTimings(
                reconstruction_ms=round(reconstruction_ms, 2),
                codegen_ms=round(codegen_ms, 2),
                execution_ms=round(execution_ms, 2),
                answering_ms=round(answering_ms, 2),
                total_ms=round((time.perf_counter() - started) * 1e3, 2),
            ),
        )

    @staticmethod
    def _check_views(intent: QuestionIntent, num_images: int) -> None:
        """A question naming a view that does not exist is bad input (422), whoever writes the program."""
        for view in [*intent.mentioned_views, *([intent.asked_view] if intent.asked_view else [])]:
            if not 1 <= view <= num_images:
                raise SolveError(
                    422,
                    f"cannot plan a program for this question: the question names view {view}, "
                    f"but there are {num_images} image(s)",
                )

    def _generate(
        self, question: str, intent: QuestionIntent, input_pngs: list[bytes], execute, max_repairs: int | None
    ) -> tuple[list[AttemptRecord], str | None, str, str | None, str | None]:
        """The attempts, the program that ran (or None), the name of what wrote it, why the offline
        planner wrote none (None when it did or was not asked), and why a fallback wrote it."""
        repairs = self.settings.max_repairs if max_repairs is None else max_repairs
        if self.code_client is None:
            attempts, program, unplannable = self._plan_offline(intent, len(input_pngs), execute)
            return attempts, program, OFFLINE_PLANNER, unplannable, None
        generated = generate_program(
            self.code_client,
            question,
            input_pngs,
            execute,
            max_repairs=repairs,
            num_examples=self.settings.num_examples,
            intent=intent,
            attach_images=not self.settings.code_model_text_only,
            max_reply_chars=self.settings.max_reply_chars,
        )
        attempts = [
            AttemptRecord(
                program=_encodable(a.program),
                error=_encodable(a.error),
                reply=_encodable(a.reply),
                latency_ms=round(a.latency_ms, 2),
                error_kind=a.error_kind,
                dropped=a.dropped,
                temperature=a.temperature,
                prompt_tokens=a.prompt_tokens,
                completion_tokens=a.completion_tokens,
            )
            for a in generated.attempts
        ]
        if generated.failure == "model":
            if isinstance(generated.model_error, ModelConfigurationError):
                # A rejected key or a server that cannot take our messages: an operator must fix a
                # setting, and a fallback would hide that. The client gets a 502 saying what to fix.
                raise generated.model_error
            # The model could not be reached even after retries: the planner still gives an honest
            # result, and the response says who wrote the program and why.
            log.warning("code model failed (%s); falling back to the offline planner", generated.error)
            planned, program, unplannable = self._plan_offline(intent, len(input_pngs), execute)
            return (
                [*attempts, *planned],
                program,
                f"{OFFLINE_PLANNER} (fallback: {self.code_model_name} failed)",
                unplannable,
                f"{self.code_model_name} failed: {generated.error}",
            )
        program = _encodable(generated.program) if generated.ok else None
        return attempts, program, self.code_model_name, None, None

    @staticmethod
    def _plan_offline(
        intent: QuestionIntent, num_images: int, execute
    ) -> tuple[list[AttemptRecord], str | None, str | None]:
        try:
            planned = plan_intent(intent, num_images)
        except PlanningError as error:  # e.g. the question names image 5 of 3
            raise SolveError(422, f"cannot plan a program for this question: {error}") from error
        except UnplannableQuestion as unplannable:
            return [], None, f"the offline planner has no program for this question: {unplannable.reason}"
        run_started = time.perf_counter()
        outcome = execute(planned.source, written_by_model=False)
        attempt = AttemptRecord(
            program=planned.source,
            error=outcome.error,
            reply=None,
            latency_ms=round((time.perf_counter() - run_started) * 1e3, 2),
        )
        return [attempt], planned.source if outcome.ok else None, None


def _encodable(text: str | None) -> str | None:
    """A model's text in the response: lone surrogates (valid in JSON, not in UTF-8) replaced."""
    return None if text is None else clean_text(text)
