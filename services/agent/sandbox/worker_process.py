"""One sandbox worker process, seen from the parent: start it, hand it its job, answer its tool
calls, and read its result or why it died.

Both the runner (which decides what runs and serves the real tools) and the jail's start-up probe
(one trivial program through the real jailed command) start workers through `run_worker`; neither
imports the other.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import signal
import subprocess
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from services.agent.sandbox.messages import Call, Ready, Result, child_message
from services.agent.sandbox.protocol import ChildStreams, ProtocolError, send_before

REPO_ROOT = Path(__file__).resolve().parents[3]
# -I: no PYTHON* variables, no user site, no current directory on sys.path.
BOOT = (
    f"import sys; sys.path.insert(0, {str(REPO_ROOT)!r}); "
    "from services.agent.sandbox.worker import main; main()"
)
# In the jail: -S as well (no site-packages scan, no .pth files); sys.path is exactly what is mounted.
JAILED_BOOT = (
    "import sys; sys.path[:0] = {paths!r}; from services.agent.sandbox.worker import main; main(jailed=True)"
)
MAX_TOOL_ERROR_CHARS = 1000
log = logging.getLogger("pyspatial.sandbox")


@dataclass
class SandboxLimits:
    cpu_seconds: int = 20
    wall_seconds: float = 60.0  # program time, the parent's tool calls included
    memory_mb: int = 2048
    max_output_chars: int = 20_000
    max_images: int = 8
    max_tool_calls: int = 32
    startup_seconds: float = 30.0  # interpreter + numpy import, before the program's clock starts


@dataclass
class ExecutionResult:
    ok: bool
    error: str | None = None
    # rejected | timeout | cpu | memory | exception | output | tool_limit | crash | jail | cpu_budget
    error_kind: str | None = None
    clue_text: str | None = None
    clue_images: list[bytes] = field(default_factory=list)
    stdout: str = ""
    tool_calls: list[str] = field(default_factory=list)
    duration_ms: float = 0.0
    cpu_seconds: float = 0.0  # the worker's process tree, measured by the parent


class ToolFailure(Exception):
    """A tool request that could not be served; its message goes back to the program."""


class ToolServer(Protocol):
    """What a conversation needs from the parent's side of the tools."""

    limit_exceeded: bool  # the program asked for more tool calls than it may make

    def handle(self, tool: Any, arguments: Any) -> Any:
        """The JSON value of a tool call; raises ToolFailure with the message for the program."""

    def image_bytes(self, handle: Any) -> bytes:
        """PNG of an image handle the program returned; ProtocolError for a handle never given out."""


class CancelSignal(Protocol):
    """Something that can say, from another thread, that the run is no longer wanted (the agent's
    `Cancellation`): the worker's process group is killed the moment it fires."""

    def on_cancel(self, callback: Callable[[], None]) -> AbstractContextManager[None]:
        """Call `callback` if the signal fires while the block runs."""


def job_message(
    source: str, question: str, num_images: int, limits: SandboxLimits, python_checks: bool
) -> dict[str, Any]:
    """The one message that tells a started worker what to run and within which limits."""
    return {
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


def child_environment(home: str) -> dict[str, str]:
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


def failure(error: str, kind: str, **extra: Any) -> ExecutionResult:
    return ExecutionResult(ok=False, error=error, error_kind=kind, **extra)


def run_worker(
    command: list[str],
    cwd: str,
    environment: dict[str, str],
    job: dict[str, Any],
    server: ToolServer,
    limits: SandboxLimits,
    cancel: CancelSignal | None = None,
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
    stop_on_cancel = cancel.on_cancel(lambda: _kill_group(process)) if cancel else contextlib.nullcontext()
    try:
        with stop_on_cancel:
            result = _converse(process, job, server, limits)
        if process.returncode is None:  # still there (not reaped by _death): read /proc before the kill
            result.cpu_seconds = process_tree_cpu_seconds(process.pid)
        return result
    finally:
        _kill(process)


_CLOCK_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def process_tree_cpu_seconds(pid: int) -> float:
    """CPU (user + system) of `pid` and all its descendants, live or reaped, from /proc; read by the
    parent before it kills the tree, so a worker cannot misreport its own use. 0 off Linux."""
    total, pending, seen = 0, [pid], set()
    while pending:
        current = pending.pop()
        if current in seen:
            continue
        seen.add(current)
        try:
            fields = Path(f"/proc/{current}/stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        # after ')': state is field 3, so utime/stime/cutime/cstime (14-17) sit at 11-14 here; a
        # zombie (the worker ended by itself) still shows them, its reaped children's included
        total += sum(int(value) for value in fields[11:15])
        try:
            pending.extend(
                int(child) for child in Path(f"/proc/{current}/task/{current}/children").read_text().split()
            )
        except OSError:
            pass
    return total / _CLOCK_TICKS


def _converse(
    process: subprocess.Popen, job: dict[str, Any], server: ToolServer, limits: SandboxLimits
) -> ExecutionResult:
    # A result carries the clue text and stdout, each escaped to at most 12 ASCII bytes a character.
    max_frame = 24 * limits.max_output_chars + (1 << 20)
    streams = ChildStreams(process.stdout.fileno(), process.stderr.fileno(), max_frame)
    try:
        try:
            ready = streams.next_message(time.monotonic() + limits.startup_seconds)
        except TimeoutError:
            return failure(f"the sandbox did not start within {limits.startup_seconds:g} s", "crash")
        if ready is None:
            return _death(process, streams, limits)
        child_message(ready, (Ready,))
        stdin_fd = process.stdin.fileno()
        os.set_blocking(stdin_fd, False)
        send_before(stdin_fd, job, time.monotonic() + limits.startup_seconds)
        # One clock for the program and the tools it calls: a loop of cheap calls is bounded too.
        deadline = time.monotonic() + limits.wall_seconds
        while True:
            raw = streams.next_message(deadline)
            if raw is None:
                return _death(process, streams, limits)
            message = child_message(raw, (Call, Result))
            if isinstance(message, Result):
                return _collect(message, server, limits)
            reply = _serve(server, message)
            if server.limit_exceeded:
                return failure(_tool_limit_error(limits), "tool_limit")
            if time.monotonic() >= deadline:
                raise TimeoutError
            send_before(stdin_fd, reply, deadline)
    except TimeoutError:
        return failure(f"timed out after {limits.wall_seconds:g} s (tool calls included)", "timeout")
    except (BrokenPipeError, ConnectionResetError):
        return _death(process, streams, limits)
    except ProtocolError as error:
        return failure(f"the sandbox broke its protocol: {error}", "crash")
    finally:
        streams.close()


def _tool_limit_error(limits: SandboxLimits) -> str:
    return f"too many tool calls: the limit is {limits.max_tool_calls} per program"


def _serve(server: ToolServer, message: Call) -> dict[str, Any]:
    try:
        value = server.handle(message.tool, message.arguments)
    except ToolFailure as error:
        return {"type": "reply", "ok": False, "error": str(error)}
    return {"type": "reply", "ok": True, "value": value}


def _collect(message: Result, server: ToolServer, limits: SandboxLimits) -> ExecutionResult:
    stdout = message.stdout[: limits.max_output_chars]
    if server.limit_exceeded:
        return failure(_tool_limit_error(limits), "tool_limit", stdout=stdout)
    if not message.ok:
        if message.kind is None:
            raise ProtocolError("a failed result must name its kind")
        error = str(message.error)[: 4 * MAX_TOOL_ERROR_CHARS]
        if message.kind == "crash":  # the sandbox's own failure: its paths are not the model's business
            error = _PATH.sub("<path>", error)
        return failure(error, message.kind, stdout=stdout)
    text, handles = message.text, message.images
    if text is not None and len(text) > limits.max_output_chars:
        raise ProtocolError("result text is not a bounded string")
    if len(handles) > limits.max_images:
        raise ProtocolError("result images are not a bounded list")
    try:
        images = [server.image_bytes(handle) for handle in handles]
    except ProtocolError:
        raise
    except Exception as error:  # the provider failed to hand over an input image
        return failure(f"get_input_image failed: {type(error).__name__}: {error}", "exception", stdout=stdout)
    return ExecutionResult(ok=True, clue_text=text, clue_images=images, stdout=stdout)


def _death(process: subprocess.Popen, streams: ChildStreams, limits: SandboxLimits) -> ExecutionResult:
    """Explain why the sandbox process ended without a result, from its exit status and stderr."""
    seen_alive = process_tree_cpu_seconds(process.pid)  # the tree as far as it still stands
    try:
        code, reaped = _reap(process, timeout=2)
    except subprocess.TimeoutExpired:
        return failure("the sandbox stopped talking without exiting", "crash")
    result = _death_reason(process, code, streams, limits)
    result.cpu_seconds = max(seen_alive, reaped)
    if result.error_kind == "cpu":  # RLIMIT_CPU fired: at least the limit was used, however it died
        result.cpu_seconds = max(result.cpu_seconds, float(limits.cpu_seconds))
    return result


def _reap(process: subprocess.Popen, timeout: float) -> tuple[int, float]:
    """Wait for the worker's exit; its status and the CPU of its whole tree (wait4's usage counts
    the descendants it reaped), which /proc no longer shows once it is gone."""
    deadline = time.monotonic() + timeout
    while True:
        pid, status, usage = os.wait4(process.pid, os.WNOHANG)
        if pid:
            process.returncode = os.waitstatus_to_exitcode(status)
            return process.returncode, usage.ru_utime + usage.ru_stime
        if time.monotonic() >= deadline:
            raise subprocess.TimeoutExpired(process.args, timeout)
        time.sleep(0.01)


def _death_reason(
    process: subprocess.Popen, code: int, streams: ChildStreams, limits: SandboxLimits
) -> ExecutionResult:
    if code > 128 and process.args and os.path.basename(str(process.args[0])) == "bwrap":
        code = -(code - 128)  # bubblewrap reports a signalled child as 128 + signal
    stderr = streams.drain_stderr()
    if stderr.strip():  # the full text for operators; the model and the user see scrubbed_stderr()
        log.warning("sandbox worker ended with status %s; its stderr:\n%s", code, stderr)
    if code == -signal.SIGXCPU:  # sent only by RLIMIT_CPU
        return failure(f"CPU time limit exceeded ({limits.cpu_seconds} s)", "cpu")
    if code == -signal.SIGKILL:  # the parent kills only after the conversation
        return failure(
            f"the sandbox process was killed by SIGKILL: the CPU hard limit ({limits.cpu_seconds} s) "
            "or the system's out-of-memory killer",
            "cpu",
        )
    detail = scrubbed_stderr(stderr)
    if code < 0:
        name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else str(-code)
        return failure(f"the sandbox process crashed with {name} {detail}".strip(), "crash")
    detail = f": {detail}" if detail else ""
    return failure(f"the sandbox process exited with status {code} without a result{detail}", "crash")


MAX_SCRUBBED_CHARS = 300
_PROGRAM_LINE = re.compile(r'File "<program>", line (\d+)')
_FATAL = re.compile(r"^Fatal Python error: (.+)$", re.MULTILINE)
_EXCEPTION = re.compile(r"^([A-Za-z][\w.]*(?:Error|Exception|Exit|Interrupt)): ?(.*)$", re.MULTILINE)
_PATH = re.compile(r"(?:/[\w.+@-]+){2,}/?|[A-Za-z]:\\[^\s'\"]+")
_ADDRESS = re.compile(r"0x[0-9a-fA-F]{6,}")


def scrubbed_stderr(stderr: str) -> str:
    """What the worker's stderr may tell the model and the user: the exception (or fatal error) type
    and message, with paths and addresses removed, and the program lines it names; bounded. Nothing
    else of the text (the interpreter's paths, versions, frames of the sandbox itself) leaves."""
    fatal = _FATAL.findall(stderr)
    exceptions = _EXCEPTION.findall(stderr)
    if fatal:
        what = fatal[-1].strip()
    elif exceptions:
        name, message = exceptions[-1]
        what = f"{name.rsplit('.', 1)[-1]}: {message.strip()}" if message.strip() else name.rsplit(".", 1)[-1]
    else:
        what = ""
    what = _ADDRESS.sub("0x…", _PATH.sub("<path>", what))
    what = "".join(character if character.isprintable() else "?" for character in what)
    lines = list(dict.fromkeys(_PROGRAM_LINE.findall(stderr)))
    where = f" while running program line {lines[0]}" if lines else ""
    text = (f"({what})" if what else "") + where
    return text.strip()[:MAX_SCRUBBED_CHARS]


def _descendants(pid: int) -> list[int]:
    """Every live descendant of `pid` (from /proc): the jailed worker sits in its own session."""
    found, pending = [], [pid]
    while pending:
        current = pending.pop()
        try:
            children = [
                int(child) for child in Path(f"/proc/{current}/task/{current}/children").read_text().split()
            ]
        except OSError:
            continue
        found += children
        pending += children
    return found


def _kill_group(process: subprocess.Popen) -> None:
    # bubblewrap's --new-session puts the worker outside this process group: kill it by pid too,
    # rather than waiting for --die-with-parent to reach it
    targets = _descendants(process.pid)
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    for pid in targets:
        try:
            os.kill(pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass


def _kill(process: subprocess.Popen) -> None:
    _kill_group(process)
    process.wait()
    for stream in (process.stdin, process.stdout, process.stderr):
        if stream is not None:
            try:
                stream.close()
            except OSError:
                pass
