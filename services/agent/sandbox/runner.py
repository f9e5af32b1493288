"""Parent side: validate a program, run it in a fresh limited process, serve its tool calls."""

from __future__ import annotations

import io
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from PIL import Image as PILImage

from services.agent.sandbox import jail
from services.agent.sandbox.jail import JailMode, JailStatus
from services.agent.sandbox.protocol import TOOL_NAMES, ChildStreams, ProtocolError, send_before
from services.agent.sandbox.text import clean_text
from services.agent.sandbox.validation import MAX_PROGRAM_CHARS, ProgramRejected, validate_program

REPO_ROOT = Path(__file__).resolve().parents[3]
# -I: no PYTHON* variables, no user site, no current directory on sys.path.
_BOOT = (
    f"import sys; sys.path.insert(0, {str(REPO_ROOT)!r}); "
    "from services.agent.sandbox.worker import main; main()"
)
# In the jail: -S as well (no site-packages scan, no .pth files); sys.path is exactly what is mounted.
_JAILED_BOOT = (
    "import sys; sys.path[:0] = {paths!r}; from services.agent.sandbox.worker import main; main(jailed=True)"
)
_JAILED_STATUS = JailStatus(JailMode.REQUIRED, True, "")
MIN_RENDER_SIZE = 16
MAX_RENDER_SIZE = 2048
MAX_TOOL_ERROR_CHARS = 1000


class ToolProvider(Protocol):
    """The real pySpatial tools of one scene, called by the parent on the program's behalf."""

    def reconstruct(self) -> dict:
        """{"extrinsics": [3x4...], "intrinsics": [3x3...], "image_sizes": [[w, h]...],
        "registered": [bool...]}, optionally "up": [x, y, z] and "warnings": [str...]."""

    def describe_camera_motion(self) -> list[str]:
        """One sentence per consecutive pair of views."""

    def synthesize_novel_view(self, extrinsic: list[list[float]], width: int, height: int) -> bytes:
        """PNG of the scene seen from `extrinsic` (3x4 camera-from-world)."""

    def input_image(self, index: int) -> bytes:
        """PNG of input view `index` (0-based)."""


@dataclass
class SandboxLimits:
    cpu_seconds: int = 20
    wall_seconds: float = 60.0  # program time; waiting for the parent's tools does not count
    memory_mb: int = 2048
    max_output_chars: int = 20_000
    max_images: int = 8
    max_tool_calls: int = 32
    startup_seconds: float = 30.0  # interpreter + numpy import, before the program's clock starts


@dataclass
class ExecutionResult:
    ok: bool
    error: str | None = None
    # rejected | timeout | cpu | memory | exception | output | tool_limit | crash | jail
    error_kind: str | None = None
    clue_text: str | None = None
    clue_images: list[bytes] = field(default_factory=list)
    stdout: str = ""
    tool_calls: list[str] = field(default_factory=list)
    duration_ms: float = 0.0


_CHILD_FAILURE_KINDS = ("rejected", "memory", "exception", "output", "crash")


class _ToolFailure(Exception):
    """A tool request that could not be served; its message goes back to the program."""


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

    def handle(self, tool: Any, arguments: Any) -> Any:
        if tool not in TOOL_NAMES or not isinstance(arguments, dict):
            raise _ToolFailure(f"unknown tool {tool!r}")
        if len(self.calls) >= self.limits.max_tool_calls:
            self.limit_exceeded = True
            raise _ToolFailure(f"tool call limit reached ({self.limits.max_tool_calls} calls per program)")
        self.calls.append(tool)
        try:
            return getattr(self, f"_{tool}")(arguments)
        except _ToolFailure:
            raise
        except Exception as error:  # the provider's failure becomes the program's ToolError
            message = f"{tool} failed: {type(error).__name__}: {error}"
            raise _ToolFailure(message[:MAX_TOOL_ERROR_CHARS]) from None

    def _reconstruct(self, arguments: dict) -> dict:
        if self.reconstruction is None:
            self.reconstruction = _plain(self.tools.reconstruct())
        return self.reconstruction

    def _describe_camera_motion(self, arguments: dict) -> list[str]:
        if self.motion is None:
            self.motion = [str(sentence) for sentence in self.tools.describe_camera_motion()]
        return self.motion

    def _synthesize_novel_view(self, arguments: dict) -> dict:
        extrinsic = _checked_extrinsic(arguments.get("extrinsic"))
        width, height = arguments.get("width"), arguments.get("height")
        for value in (width, height):
            if type(value) is not int or not MIN_RENDER_SIZE <= value <= MAX_RENDER_SIZE:
                raise _ToolFailure(
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
            raise _ToolFailure(f"input image index must be 0..{self.num_images - 1}")
        width, height = _png_size(self.input_png(index))
        return {"width": width, "height": height}

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


def _checked_extrinsic(value: Any) -> list[list[float]]:
    try:
        matrix = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise _ToolFailure("extrinsic must be a 3x4 matrix of numbers") from None
    if matrix.shape != (3, 4) or not np.all(np.isfinite(matrix)):
        raise _ToolFailure("extrinsic must be a 3x4 matrix of finite numbers")
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


def _child_environment(home: str) -> dict[str, str]:
    threads = "1"  # one BLAS thread: cheaper start, and the CPU limit means what it says
    return {
        "PATH": "/usr/bin:/bin",
        "HOME": home,
        "TMPDIR": home,
        "LANG": "C.UTF-8",
        "OPENBLAS_NUM_THREADS": threads,
        "OMP_NUM_THREADS": threads,
        "MKL_NUM_THREADS": threads,
    }


def _failure(error: str, kind: str, **extra: Any) -> ExecutionResult:
    return ExecutionResult(ok=False, error=error, error_kind=kind, **extra)


def run_program(
    source: str,
    question: str,
    num_images: int,
    tools: ToolProvider,
    limits: SandboxLimits | None = None,
    jail_status: JailStatus | None = None,
    python_checks: bool = True,
) -> ExecutionResult:
    """Run `def program(input_scene)` from `source` in a sandbox process and collect its clue.

    `jail_status` defaults to the probed OS jail (PYSPATIAL_SANDBOX_JAIL=required): without a working
    jail nothing runs. `python_checks=False` is a test-only mode that proves the jail on its own.
    """
    limits = limits or SandboxLimits()
    jail_status = jail_status or jail.probe(JailMode.REQUIRED)
    started = time.perf_counter()
    if not jail_status.runs_programs:
        return _failure(
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
            return _failure(f"rejected: {error}", "rejected", duration_ms=_ms_since(started))
    broker = _ToolBroker(tools, num_images, limits)
    job = {
        "type": "job",
        "source": source,
        "question": question,
        "num_images": num_images,
        "python_checks": python_checks,
        "limits": {
            "cpu_seconds": limits.cpu_seconds,
            "memory_mb": limits.memory_mb,
            "max_output_chars": limits.max_output_chars,
            "max_images": limits.max_images,
        },
    }
    if jail_status.jailed:
        boot = _JAILED_BOOT.format(paths=list(jail.python_path()))
        command = jail.bwrap_command(["-I", "-S", "-c", boot])
        result = _run_child(command, "/", _child_environment("/tmp"), job, broker, limits)
    else:  # operator opt-out: a host temporary directory, Python-level walls and rlimits only
        with tempfile.TemporaryDirectory(prefix=jail.workdir_prefix()) as workdir:
            command = [sys.executable, "-I", "-c", _BOOT]
            result = _run_child(command, workdir, _child_environment(workdir), job, broker, limits)
    result.tool_calls = list(broker.calls)
    result.duration_ms = _ms_since(started)
    return _cleaned(result)


def _run_child(
    command: list[str],
    cwd: str,
    environment: dict[str, str],
    job: dict[str, Any],
    broker: _ToolBroker,
    limits: SandboxLimits,
) -> ExecutionResult:
    process = subprocess.Popen(
        command,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=cwd,
        env=environment,
        start_new_session=True,  # its own process group: one kill takes everything it started
        close_fds=True,
    )
    try:
        return _converse(process, job, broker, limits)
    finally:
        _kill(process)


def _cleaned(result: ExecutionResult) -> ExecutionResult:
    """Text that crosses into HTTP responses and model prompts must be encodable (no lone surrogates)."""
    result.error = clean_text(result.error) if result.error is not None else None
    result.clue_text = clean_text(result.clue_text) if result.clue_text is not None else None
    result.stdout = clean_text(result.stdout)
    return result


def probe_jail() -> str | None:
    """Run one trivial program in the jail; None when it worked, else what went wrong."""
    source = "def program(input_scene):\n    return 'jail ok'\n"
    limits = SandboxLimits(cpu_seconds=10, wall_seconds=20, memory_mb=1024, startup_seconds=30)
    try:
        result = run_program(source, "", 0, _NoTools(), limits, jail_status=_JAILED_STATUS)
    except OSError as error:
        return f"{type(error).__name__}: {error}"
    if result.ok and result.clue_text == "jail ok":
        return None
    return result.error or "the probe program returned something else"


class _NoTools:
    def reconstruct(self) -> dict:
        raise RuntimeError("no tools in the probe")

    describe_camera_motion = synthesize_novel_view = input_image = reconstruct


def _converse(
    process: subprocess.Popen, job: dict[str, Any], broker: _ToolBroker, limits: SandboxLimits
) -> ExecutionResult:
    max_line = 4 * limits.max_output_chars + (1 << 20)
    streams = ChildStreams(process.stdout.fileno(), process.stderr.fileno(), max_line)
    try:
        try:
            ready = streams.next_message(time.monotonic() + limits.startup_seconds)
        except TimeoutError:
            return _failure(f"the sandbox did not start within {limits.startup_seconds:g} s", "crash")
        if ready is None or ready.get("type") != "ready":
            return _death(process, streams, limits)
        stdin_fd = process.stdin.fileno()
        os.set_blocking(stdin_fd, False)
        send_before(stdin_fd, job, time.monotonic() + limits.startup_seconds)
        clock_start, tool_seconds = time.monotonic(), 0.0
        while True:
            deadline = clock_start + limits.wall_seconds + tool_seconds
            message = streams.next_message(deadline)
            if message is None:
                return _death(process, streams, limits)
            if message["type"] == "result":
                return _collect(message, broker, limits)
            if message["type"] != "call":
                raise ProtocolError(f"unexpected message type {message['type']!r}")
            tool_started = time.monotonic()
            reply = _serve(broker, message)
            tool_seconds += time.monotonic() - tool_started
            send_before(stdin_fd, reply, clock_start + limits.wall_seconds + tool_seconds)
    except TimeoutError:
        return _failure(f"timed out after {limits.wall_seconds:g} s", "timeout")
    except (BrokenPipeError, ConnectionResetError):
        return _death(process, streams, limits)
    except ProtocolError as error:
        return _failure(f"the sandbox broke its protocol: {error}", "crash")
    finally:
        streams.close()


def _serve(broker: _ToolBroker, message: dict[str, Any]) -> dict[str, Any]:
    try:
        value = broker.handle(message.get("tool"), message.get("arguments"))
    except _ToolFailure as error:
        return {"type": "reply", "ok": False, "error": str(error)}
    return {"type": "reply", "ok": True, "value": value}


def _collect(message: dict[str, Any], broker: _ToolBroker, limits: SandboxLimits) -> ExecutionResult:
    stdout, error = message.get("stdout") or "", message.get("error")
    if not isinstance(stdout, str) or (error is not None and not isinstance(error, str)):
        raise ProtocolError("result stdout and error must be strings")
    stdout = stdout[: limits.max_output_chars]
    if broker.limit_exceeded:
        error = f"too many tool calls: the limit is {limits.max_tool_calls} per program"
        return _failure(error, "tool_limit", stdout=stdout)
    if not message.get("ok"):
        kind = message.get("kind")
        if kind not in _CHILD_FAILURE_KINDS:
            raise ProtocolError(f"unknown failure kind {str(kind)[:40]!r}")
        return _failure(str(error)[: 4 * MAX_TOOL_ERROR_CHARS], kind, stdout=stdout)
    text, handles = message.get("text"), message.get("images") or []
    if text is not None and (not isinstance(text, str) or len(text) > limits.max_output_chars):
        raise ProtocolError("result text is not a bounded string")
    if not isinstance(handles, list) or len(handles) > limits.max_images:
        raise ProtocolError("result images are not a bounded list")
    try:
        images = [broker.image_bytes(handle) for handle in handles]
    except ProtocolError:
        raise
    except Exception as error:  # the provider failed to hand over an input image
        return _failure(
            f"get_input_image failed: {type(error).__name__}: {error}", "exception", stdout=stdout
        )
    return ExecutionResult(ok=True, clue_text=text, clue_images=images, stdout=stdout)


def _death(process: subprocess.Popen, streams: ChildStreams, limits: SandboxLimits) -> ExecutionResult:
    """Explain why the sandbox process ended without a result, from its exit status and stderr."""
    try:
        code = process.wait(timeout=2)
    except subprocess.TimeoutExpired:
        return _failure("the sandbox stopped talking without exiting", "crash")
    if code > 128 and process.args and os.path.basename(str(process.args[0])) == "bwrap":
        code = -(code - 128)  # bubblewrap reports a signalled child as 128 + signal
    stderr = streams.drain_stderr()
    if code == -signal.SIGXCPU:  # sent only by RLIMIT_CPU
        return _failure(f"CPU time limit exceeded ({limits.cpu_seconds} s)", "cpu")
    if code == -signal.SIGKILL:  # the parent kills only after the conversation
        return _failure(
            f"the sandbox process was killed by SIGKILL: the CPU hard limit ({limits.cpu_seconds} s) "
            "or the system's out-of-memory killer",
            "cpu",
        )
    if code < 0:
        name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else str(-code)
        return _failure(f"the sandbox process crashed with {name}{_crash_site(stderr)}", "crash")
    last_line = (stderr.strip().splitlines() or [""])[-1]
    detail = f": {last_line[:MAX_TOOL_ERROR_CHARS]}" if last_line else ""
    return _failure(f"the sandbox process exited with status {code} without a result{detail}", "crash")


_FAULT_LINE = re.compile(r'File "<program>", line (\d+)')
_FAULT_KIND = re.compile(r"Fatal Python error: ([^\n]+)")


def _crash_site(stderr: str) -> str:
    """What faulthandler wrote: the fatal error and the program line that was running."""
    kind = _FAULT_KIND.search(stderr)
    lines = _FAULT_LINE.findall(stderr)
    parts = []
    if kind:
        parts.append(f" ({kind.group(1).strip()[:200]})")
    if lines:
        parts.append(f" while running program line {lines[0]}")
    return "".join(parts)


def _kill(process: subprocess.Popen) -> None:
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    process.wait()
    for stream in (process.stdin, process.stdout, process.stderr):
        if stream is not None:
            try:
                stream.close()
            except OSError:
                pass


def _ms_since(started: float) -> float:
    return round((time.perf_counter() - started) * 1e3, 1)
