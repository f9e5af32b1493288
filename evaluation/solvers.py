"""The two systems the harness compares: pySpatial (the agent service) and the answer model alone.

Both turn a BenchmarkItem into a Prediction and never raise for a failed request: the failure is
recorded on the prediction and the item counts as wrong.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from evaluation.dataset import BenchmarkItem
from evaluation.exact_scenes import ExactSceneUploader
from services.agent.llm import ChatClient, ChatModelConfig, LLMError, image_part, text_part
from shared.imaging.codecs import decode_image, encode_image
from shared.wire.client import AgentClient, ReconClient, ServiceError, ServiceUnreachable
from shared.wire.settings import AgentSettings

PYSPATIAL_SUFFIX = " + pySpatial"


@dataclass
class Prediction:
    system: str  # "<answer model> + pySpatial", or the model name alone for the baseline
    answer: str | None  # the agent's letter, or the baseline model's whole reply
    text: str = ""  # reasoning (agent) or raw reply (baseline): the source of free-form answers
    answer_reason: str | None = None
    program_produced: bool | None = None  # None: not applicable (no program in the baseline)
    executed: bool | None = None
    program: str | None = None
    error: str | None = None
    timings: dict[str, float | None] | None = None
    scene_id: str | None = None
    backbone: str | None = None
    code_model: str | None = None  # what wrote the program ("offline-planner (fallback: ...)" included)
    answer_model: str | None = None  # what answered
    fallback: str | None = None  # "images_only": no program ran, the photos alone were used
    fallback_reason: str | None = None
    family: str | None = None  # the question's family as the agent parsed it

    def as_record(self) -> dict[str, Any]:
        return {
            "system": self.system,
            "raw_answer": self.answer,
            "text": self.text,
            "answer_reason": self.answer_reason,
            "program_produced": self.program_produced,
            "executed": self.executed,
            "program": self.program,
            "error": self.error,
            "timings": self.timings,
            "scene_id": self.scene_id,
            "backbone": self.backbone,
            "code_model": self.code_model,
            "answer_model": self.answer_model,
            "fallback": self.fallback,
            "fallback_reason": self.fallback_reason,
            "family": self.family,
        }


class PySpatialSolver:
    """Calls POST /v1/solve; with exact scene data (posed-rgbd) the scene is uploaded first."""

    def __init__(
        self, agent: AgentClient, backbone: str | None = None, uploader: ExactSceneUploader | None = None
    ) -> None:
        self._agent = agent
        self._backbone = backbone
        self._uploader = uploader

    def solve(self, item: BenchmarkItem) -> Prediction:
        label = f"pySpatial ({self._backbone or 'default backbone'})"
        try:
            scene_id = self._uploader.scene_id(item) if self._uploader else None
            if scene_id is not None:
                response = self._agent.solve(item.question, scene_id=scene_id, backbone=self._backbone)
            else:
                response = self._agent.solve(item.question, images=item.images, backbone=self._backbone)
        except (ServiceError, ServiceUnreachable) as error:
            return Prediction(system=label, answer=None, error=str(error), backbone=self._backbone)
        return Prediction(
            system=response.answer_model + PYSPATIAL_SUFFIX,
            answer=response.answer,
            text=response.reasoning,
            answer_reason=response.answer_reason,
            program_produced=any(attempt.program for attempt in response.attempts),
            # The response's program is "the exact code that ran": set only when a run succeeded.
            executed=response.program is not None,
            program=response.program,
            timings=response.timings.model_dump(),
            scene_id=response.scene_id,
            backbone=response.backbone,
            code_model=response.code_model,
            answer_model=response.answer_model,
            fallback=response.fallback,
            fallback_reason=response.fallback_reason,
            family=response.intent.family if response.intent else None,
        )


def _model_image(path: Path) -> tuple[bytes, str]:
    """Image bytes and their MIME type; formats other than PNG and JPEG are re-encoded as PNG."""
    data = path.read_bytes()
    if data.startswith(b"\x89PNG"):
        return data, "image/png"
    if data.startswith(b"\xff\xd8"):
        return data, "image/jpeg"
    rgb = decode_image(data, max_bytes=len(data) + 1, max_pixels=10**9, label=str(path))
    return encode_image(rgb, "png"), "image/png"


class BaselineSolver:
    """The answer model alone: the question and the images, no program and no 3D tools."""

    def __init__(self, chat: ChatClient, instruction: str) -> None:
        self._chat = chat
        self._instruction = instruction

    @property
    def model(self) -> str:
        return self._chat.config.model

    def solve(self, item: BenchmarkItem) -> Prediction:
        content = [text_part(f"{item.question}\n\n{self._instruction}")]
        for path in item.images:
            data, mime = _model_image(path)
            content.append(image_part(data, mime))
        try:
            reply = self._chat.complete([{"role": "user", "content": content}])
        except LLMError as error:
            return Prediction(system=self.model, answer=None, error=str(error))
        return Prediction(
            system=self.model,
            answer=reply.text,
            text=reply.text,
            answer_model=self.model,
            timings={
                "codegen_ms": None,
                "execution_ms": None,
                "answering_ms": reply.latency_ms,
                "total_ms": reply.latency_ms,
            },
        )


def solve_safely(solve: Callable[[BenchmarkItem], Prediction], item: BenchmarkItem) -> Prediction:
    """The solver's prediction, or a failed one when preparing the item broke (missing file, ...)."""
    try:
        return solve(item)
    except Exception as error:  # one broken item is that item's wrong answer, not the end of the run
        return Prediction(system="unknown", answer=None, error=f"{type(error).__name__}: {error}")


POSED_RGBD = "posed-rgbd"


@contextmanager
def pyspatial_solver(
    agent_url: str,
    image_root: Path,
    backbone: str | None = None,
    recon_url: str | None = None,
    api_key: str | None = None,
    recon_api_key: str | None = None,
) -> Iterator[PySpatialSolver]:
    """A solver talking to the agent service; with ``backbone`` posed-rgbd and a ``recon_url``,
    items that carry exact cameras and depth are uploaded with them first (see exact_scenes.py).

    A key the agent refuses (401) raises ServiceError here, before any item is run."""
    with contextlib.ExitStack() as stack:
        agent = stack.enter_context(AgentClient(agent_url, api_key=api_key))
        _check_key(agent)
        uploader = None
        if backbone == POSED_RGBD and recon_url:
            recon = stack.enter_context(ReconClient(recon_url, api_key=recon_api_key))
            uploader = ExactSceneUploader(recon, image_root)
        yield PySpatialSolver(agent, backbone, uploader)


def _check_key(agent: AgentClient) -> None:
    """Stop at once on a refused key rather than record it as every item's error.

    Other failures here (recon down, agent unreachable) stay each item's error, as they were.
    """
    try:
        agent.backbones()
    except ServiceError as error:
        if error.status_code == 401:
            raise
    except ServiceUnreachable:
        pass


def answer_model_config(settings: AgentSettings, model: str | None = None) -> ChatModelConfig:
    """The configured answer model (PYSPATIAL_ANSWER_MODEL...), or a clear error without one."""
    name = model or settings.answer_model
    if not name:
        raise NoAnswerModel(
            "no answer model is configured: set PYSPATIAL_ANSWER_MODEL (and PYSPATIAL_ANSWER_MODEL_BASE_URL, "
            "PYSPATIAL_ANSWER_MODEL_API_KEY for an OpenAI-compatible endpoint) or pass --model"
        )
    return ChatModelConfig(
        base_url=settings.answer_model_base_url or "https://api.openai.com/v1",
        model=name,
        api_key=settings.answer_model_api_key,
        timeout_s=settings.model_timeout_s,
        max_retries=settings.model_max_retries,
    )


class NoAnswerModel(RuntimeError):
    """The baseline needs a real answer model and none is configured."""
