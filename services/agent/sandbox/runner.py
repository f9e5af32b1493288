"""Parent side: validate a program, run it in a fresh limited process (worker_process.py), serve its
tool calls from a `ToolProvider`."""

from __future__ import annotations

import io
import math
import sys
import tempfile
import time
from typing import Any, Protocol

import numpy as np
from PIL import Image as PILImage

from services.agent.sandbox import jail
from services.agent.sandbox.jail import JailMode, JailStatus
from services.agent.sandbox.protocol import TOOL_NAMES, ProtocolError
from services.agent.sandbox.text import clean_text
from services.agent.sandbox.validation import MAX_PROGRAM_CHARS, ProgramRejected, validate_program
from services.agent.sandbox.worker_process import (
    BOOT,
    MAX_TOOL_ERROR_CHARS,
    CancelSignal,
    ExecutionResult,
    SandboxLimits,
    ToolFailure,
    child_environment,
    failure,
    job_message,
    run_worker,
)

MIN_RENDER_SIZE = 16
MAX_RENDER_SIZE = 2048


class ToolProvider(Protocol):
    """The real pySpatial tools of one scene, called by the parent on the program's behalf."""

    def reconstruct(self) -> dict:
        """{"extrinsics": [3x4...], "intrinsics": [3x3...], "image_sizes": [[w, h]...],
        "registered": [bool...]}, optionally "up": [x, y, z] and "warnings": [str...]."""

    def describe_camera_motion(self, pair: tuple[int, int] | None = None) -> list[str]:
        """One sentence per consecutive pair of views; with `pair` (1-based from, to) that pair's."""

    def synthesize_novel_view(self, extrinsic: list[list[float]], width: int, height: int) -> bytes:
        """PNG of the scene seen from `extrinsic` (3x4 camera-from-world)."""

    def input_image(self, index: int) -> bytes:
        """PNG of input view `index` (0-based)."""

    def locate(self, view: int, u: float, v: float) -> dict:
        """{"point": [x, y, z] or None, "reason": str or None} at pixel (u, v) of the view at index
        `view` (0-based: sandbox/api.py turns the program's 1-based view number into it)."""

    def plan_route(self, start_view: int, goal: list[float], robot_radius: float) -> dict:
        """A route plan as `shared.navigation.RoutePlan.to_dict()` plus "summary"; `start_view` is an
        index (0-based), as for `locate`."""


class _ToolBroker:
    """Serves a program's tool requests and keeps every image it produced, by handle id."""

    def __init__(self, tools: ToolProvider, num_images: int, limits: SandboxLimits) -> None:
        self.tools = tools
        self.num_images = num_images
        self.limits = limits
        self.calls: list[str] = []
        self.limit_exceeded = False
        self.images: dict[str, bytes] = {}
        self.reconstruction: dict | None = None
        self.motion: list[str] | None = None
        self.pair_motion: dict[tuple[int, int], list[str]] = {}

    def handle(self, tool: Any, arguments: Any) -> Any:
        if tool not in TOOL_NAMES or not isinstance(arguments, dict):
            raise ToolFailure(f"unknown tool {tool!r}")
        if len(self.calls) >= self.limits.max_tool_calls:
            self.limit_exceeded = True
            raise ToolFailure(f"tool call limit reached ({self.limits.max_tool_calls} calls per program)")
        self.calls.append(tool)
        try:
            return getattr(self, f"_{tool}")(arguments)
        except ToolFailure:
            raise
        except Exception as error:  # the provider's failure becomes the program's ToolError
            message = f"{tool} failed: {type(error).__name__}: {error}"
            raise ToolFailure(message[:MAX_TOOL_ERROR_CHARS]) from None

    def _reconstruct(self, arguments: dict) -> dict:
        if self.reconstruction is None:
            self.reconstruction = _plain(self.tools.reconstruct())
        return self.reconstruction

    def _describe_camera_motion(self, arguments: dict) -> list[str]:
        if not arguments:
            if self.motion is None:
                self.motion = [str(sentence) for sentence in self.tools.describe_camera_motion()]
            return self.motion
        pair = (arguments.get("from_view"), arguments.get("to_view"))
        if set(arguments) != {"from_view", "to_view"} or any(
            type(view) is not int or not 1 <= view <= self.num_images for view in pair
        ):
            raise ToolFailure(f"from_view and to_view must be view numbers 1..{self.num_images}")
        if pair[0] == pair[1]:
            raise ToolFailure("from_view and to_view must be different views")
        if pair not in self.pair_motion:
            self.pair_motion[pair] = [str(s) for s in self.tools.describe_camera_motion(pair)]
        return self.pair_motion[pair]

    def _synthesize_novel_view(self, arguments: dict) -> dict:
        extrinsic = _checked_extrinsic(arguments.get("extrinsic"))
        width, height = arguments.get("width"), arguments.get("height")
        for value in (width, height):
            if type(value) is not int or not MIN_RENDER_SIZE <= value <= MAX_RENDER_SIZE:
                raise ToolFailure(
                    f"width and height must be integers from {MIN_RENDER_SIZE} to {MAX_RENDER_SIZE}"
                )
        png = self.tools.synthesize_novel_view(extrinsic, width, height)
        handle = f"view:{len(self.images)}"
        self.images[handle] = png
        real_width, real_height = _png_size(png)
        return {"id": handle, "width": real_width, "height": real_height}

    def _get_input_image(self, arguments: dict) -> dict:
        index = arguments.get("index")
        if type(index) is not int or not 0 <= index < self.num_images:
            raise ToolFailure(f"input image index must be 0..{self.num_images - 1}")
        width, height = _png_size(self.input_png(index))
        return {"width": width, "height": height}

    def _locate(self, arguments: dict) -> dict:
        view = _checked_view(arguments.get("view"), self.num_images)
        u, v = (_checked_number(arguments.get(name), name) for name in ("u", "v"))
        return _plain(self.tools.locate(view, u, v))

    def _plan_route(self, arguments: dict) -> dict:
        start = _checked_view(arguments.get("start_view"), self.num_images)
        goal = arguments.get("goal")
        if not isinstance(goal, list) or len(goal) != 3:
            raise ToolFailure("goal must be 3 numbers (a world point)")
        point = [_checked_number(value, "goal") for value in goal]
        radius = _checked_number(arguments.get("robot_radius"), "robot_radius")
        if not 0 < radius <= 5:
            raise ToolFailure("robot_radius must be in (0, 5]")
        return _plain(self.tools.plan_route(start, point, radius))

    def input_png(self, index: int) -> bytes:
        handle = f"input:{index}"
        if handle not in self.images:
            self.images[handle] = self.tools.input_image(index)
        return self.images[handle]

    def image_bytes(self, handle: Any) -> bytes:
        """PNG of a handle the program returned; input images are fetched on demand."""
        if isinstance(handle, str) and handle.startswith("input:"):
            index = handle.removeprefix("input:")
            if index.isdigit() and int(index) < self.num_images:
                if handle not in self.images:
                    self.calls.append("get_input_image")
                return self.input_png(int(index))
        if handle not in self.images:
            raise ProtocolError(f"unknown image handle {handle!r}")
        return self.images[handle]


def _checked_view(value: Any, num_images: int) -> int:
    if type(value) is not int or not 0 <= value < num_images:
        raise ToolFailure(f"view index must be 0..{num_images - 1} (the API turns view numbers into indices)")
    return value


def _checked_number(value: Any, label: str) -> float:
    if type(value) not in (int, float) or not math.isfinite(value):
        raise ToolFailure(f"{label} must be a finite number")
    return float(value)


def _checked_extrinsic(value: Any) -> list[list[float]]:
    try:
        matrix = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ToolFailure("extrinsic must be a 3x4 matrix of numbers") from None
    if matrix.shape != (3, 4) or not np.all(np.isfinite(matrix)):
        raise ToolFailure("extrinsic must be a 3x4 matrix of finite numbers")
    return matrix.tolist()


def _png_size(png: bytes) -> tuple[int, int]:
    with PILImage.open(io.BytesIO(png)) as image:  # reads the header only
        return image.size


def _plain(value: Any) -> Any:
    """A provider's reply as plain JSON types (providers may hand back numpy arrays)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {str(key): _plain(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(item) for item in value]
    return value


def run_program(
    source: str,
    question: str,
    num_images: int,
    tools: ToolProvider,
    limits: SandboxLimits | None = None,
    jail_status: JailStatus | None = None,
    python_checks: bool = True,
    cancel: CancelSignal | None = None,
) -> ExecutionResult:
    """Run `def program(input_scene)` from `source` in a sandbox process and collect its clue.

    `jail_status` defaults to the probed OS jail (PYSPATIAL_SANDBOX_JAIL=required): without a working
    jail nothing runs. `python_checks=False` is a test-only mode that proves the jail on its own.
    `cancel` fired while the program runs kills its process group at once (the solve's client left).
    """
    limits = limits or SandboxLimits()
    jail_status = jail_status or jail.probe(JailMode.REQUIRED)
    started = time.perf_counter()
    if not jail_status.runs_programs:
        return failure(
            f"refused: the OS sandbox is unavailable ({jail_status.detail}); model-written programs "
            "are not run without it (PYSPATIAL_SANDBOX_JAIL=off switches it off, unsafely)",
            "jail",
            duration_ms=_ms_since(started),
        )
    if not python_checks and not jail_status.jailed:
        raise ValueError("the Python-level checks may only be switched off inside the OS jail")
    if python_checks:
        try:
            validate_program(source, max_chars=MAX_PROGRAM_CHARS)
        except ProgramRejected as error:
            return failure(f"rejected: {error}", "rejected", duration_ms=_ms_since(started))
    broker = _ToolBroker(tools, num_images, limits)
    job = job_message(source, question, num_images, limits, python_checks)
    if jail_status.jailed:
        command, environment = jail.jailed_worker_command(), child_environment("/tmp")
        result = run_worker(command, "/", environment, job, broker, limits, cancel)
    else:  # operator opt-out: a host temporary directory, Python-level walls and rlimits only
        with tempfile.TemporaryDirectory(prefix=jail.workdir_prefix()) as workdir:
            command = [sys.executable, "-I", "-c", BOOT]
            result = run_worker(command, workdir, child_environment(workdir), job, broker, limits, cancel)
    result.tool_calls = list(broker.calls)
    result.duration_ms = _ms_since(started)
    return _cleaned(result)


def _cleaned(result: ExecutionResult) -> ExecutionResult:
    """Text that crosses into HTTP responses and model prompts must be encodable (no lone surrogates)."""
    result.error = clean_text(result.error) if result.error is not None else None
    result.clue_text = clean_text(result.clue_text) if result.clue_text is not None else None
    result.stdout = clean_text(result.stdout)
    return result


def _ms_since(started: float) -> float:
    return round((time.perf_counter() - started) * 1e3, 1)
