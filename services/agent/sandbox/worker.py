"""The sandbox process: receives one job, runs one program, reports one result, exits.

Order matters: everything trusted (imports, protocol streams) is set up first; then the process
limits are applied, an audit hook is armed, and only then does the program's code run.
Started by worker_process.py (`python -I -c ...`, in the jail `-I -S`); not meant to be run by hand.
"""

from __future__ import annotations

import builtins
import ctypes
import faulthandler
import math
import os
import resource
import signal
import sys
import warnings
from collections.abc import Callable
from types import CodeType, TracebackType
from typing import Any, BinaryIO

import numpy
import numpy.ma  # noqa: F401  (np.median imports it lazily; imports are blocked once a program runs)

from services.agent.sandbox.api import PySpatial, ToolError, build_scene
from services.agent.sandbox.builtins import (
    FORMAT_FUNCTION_NAME,
    OutputCapture,
    OutputLimitExceeded,
    hide_addresses,
    program_globals,
)
from services.agent.sandbox.output import OutputRejected, OutputTooLarge, render_output
from services.agent.sandbox.protocol import read_message, write_message
from services.agent.sandbox.text import clean_text
from services.agent.sandbox.validation import ProgramRejected, prepare_for_execution, validate_program

PROGRAM_FILENAME = "<program>"
MAX_INBOUND_BYTES = 64 * 1024 * 1024
MAX_ERROR_CHARS = 2000

# Audit events refused once the program runs (a third wall behind the validator and the builtins).
BLOCKED_EVENTS = frozenset(
    {
        "open", "import", "compile", "exec", "builtins.input", "builtins.breakpoint", "sys._getframe",
        "sys._current_frames", "sys._current_exceptions", "sys.settrace", "sys.setprofile", "code.__new__",
        "function.__new__", "sys.excepthook", "sys.unraisablehook",
    }
)  # fmt: skip
BLOCKED_EVENT_MODULES = frozenset(
    {
        "os", "subprocess", "socket", "ctypes", "shutil", "gc", "marshal", "pickle", "resource", "mmap",
        "fcntl", "pty", "signal", "webbrowser", "urllib", "http", "ftplib", "smtplib", "sqlite3", "glob",
        "tempfile", "shelve", "dbm", "syslog", "cpython", "ssl", "select", "selectors", "_posixsubprocess",
    }
)  # fmt: skip


class PipeChannel:
    """The child's end of the tool channel: one request, one reply, in order."""

    def __init__(self, reader: BinaryIO, writer: BinaryIO) -> None:
        self.reader = reader
        self.writer = writer

    def call(self, tool: str, arguments: dict[str, Any]) -> Any:
        write_message(self.writer, {"type": "call", "tool": tool, "arguments": arguments})
        reply = read_message(self.reader, MAX_INBOUND_BYTES)
        if reply.get("type") != "reply":
            raise ToolError("the sandbox lost its connection to the tools")
        if reply.get("ok"):
            return reply.get("value")
        raise ToolError(str(reply.get("error") or f"{tool} failed"))


def warm_up_numpy() -> None:
    """Run numpy's lazily initialised paths now, while imports still work.

    Printing arrays, the median and a few linalg routines import or configure numpy internals on
    first use; inside a program that would fail (no `__import__`, and the audit hook refuses imports).
    """
    matrix = numpy.array([[2.0, 1.0], [1.0, 3.0]])
    for value in (matrix, matrix[0, 0], numpy.float32(1.5), numpy.int64(2), numpy.bool_(True)):
        str(value), repr(value), format(value) if numpy.ndim(value) else format(value, ".2f")
    for method in (
        "sum",
        "mean",
        "std",
        "var",
        "max",
        "min",
        "any",
        "all",
        "prod",
        "argmax",
        "argmin",
        "cumsum",
    ):
        getattr(matrix, method)(), getattr(matrix, method)(axis=0)
    matrix.clip(0, 1), matrix.round(1), matrix.astype(numpy.float32).dtype.name, str(matrix.dtype)
    numpy.median(matrix), numpy.std(matrix), numpy.round(matrix, 2), numpy.allclose(matrix, matrix)
    numpy.linalg.inv(matrix), numpy.linalg.pinv(matrix), numpy.linalg.solve(matrix, matrix[0])
    numpy.linalg.svd(matrix), numpy.linalg.det(matrix), numpy.linalg.norm(matrix), numpy.cross(matrix, matrix)
    failing_calls = (
        lambda: numpy.linalg.inv(numpy.zeros((2, 2))),  # LinAlgError
        lambda: numpy.sum(matrix, axis=5),  # AxisError
        lambda: numpy.add(matrix, "text"),  # UFuncTypeError
        lambda: matrix.reshape(3),  # ValueError
    )
    for call in failing_calls:
        try:
            call()
        except (ValueError, TypeError, IndexError, numpy.linalg.LinAlgError):
            pass


def take_protocol_streams() -> tuple[BinaryIO, BinaryIO]:
    """Private copies of stdin/stdout for messages; fds 0 and 1 then point at /dev/null."""
    reader = os.fdopen(os.dup(0), "rb")
    writer = os.fdopen(os.dup(1), "wb")
    null = os.open(os.devnull, os.O_RDWR)
    os.dup2(null, 0)
    os.dup2(null, 1)
    os.close(null)
    return reader, writer


def die_with_parent() -> None:
    """PR_SET_PDEATHSIG(SIGKILL): a killed parent never leaves this process running."""
    PR_SET_PDEATHSIG = 1
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


# Tasks (processes and threads) the worker's user may hold: the kernel counts them at every clone,
# whatever the Python layer allows. The jailed worker is never root (host uid 65534 when the agent is
# root; the service user in its own user namespace otherwise), so the kernel enforces it; it cannot
# raise it back (no CAP_SYS_RESOURCE, and seccomp lets prlimit64 only read). As host uid 65534 the
# count is shared by every sandbox running at that moment; in a user namespace it is the worker's own.
MAX_TASKS = 32


def apply_resource_limits(cpu_seconds: int, memory_mb: int, limit_descriptors: bool = True) -> None:
    used = resource.getrusage(resource.RUSAGE_SELF)
    cpu_soft = int(used.ru_utime + used.ru_stime) + max(int(cpu_seconds), 1)
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_soft, cpu_soft + 1))  # SIGXCPU, then SIGKILL
    memory = int(memory_mb) * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    # An OS wall: set in the test-only unchecked mode too (a thread bomb there meets it alone).
    hard = resource.getrlimit(resource.RLIMIT_NPROC)[1]
    tasks = MAX_TASKS if hard == resource.RLIM_INFINITY else min(MAX_TASKS, hard)
    resource.setrlimit(resource.RLIMIT_NPROC, (tasks, tasks))  # no effect for root (opt-out mode)
    if limit_descriptors:  # the test-only unchecked mode leaves files to the OS jail alone
        resource.setrlimit(resource.RLIMIT_NOFILE, (0, 0))  # open fds stay usable; no new ones


def arm_audit_hook(program_code: CodeType) -> None:
    """Refuse file, process, network and code-loading events from here on (hooks cannot be removed).

    The block lists are frozen sets bound in this closure when the hook is armed: rebinding the
    module globals afterwards changes nothing.
    """
    blocked_events, blocked_modules = frozenset(BLOCKED_EVENTS), frozenset(BLOCKED_EVENT_MODULES)
    split = str.split

    def refuse(event: str, arguments: tuple[Any, ...]) -> None:
        if event == "exec" and arguments and arguments[0] is program_code:
            return
        if event in blocked_events or split(event, ".", 1)[0] in blocked_modules:
            raise RuntimeError(f"operation '{event}' is not allowed in the sandbox")

    sys.addaudithook(refuse)


def program_line(trace: TracebackType | None) -> int | None:
    line = None
    while trace is not None:
        if trace.tb_frame.f_code.co_filename == PROGRAM_FILENAME:
            line = trace.tb_lineno
        trace = trace.tb_next
    return line


def describe_exception(error: BaseException) -> str:
    line = program_line(error.__traceback__)
    where = f" (line {line})" if line is not None else ""
    if isinstance(error, KeyError) and error.args == ("__import__",):
        # numpy's C code tried to import a module on the program's behalf; programs have no __import__
        return f"program used a numpy feature that is not available in the sandbox{where}"
    if isinstance(error, RuntimeError) and error.args == ("can't start new thread",):
        limit = f"the sandbox allows at most {MAX_TASKS} threads and processes"
        return f"program raised RuntimeError: can't start new thread ({limit}){where}"
    try:
        message = hide_addresses(str(error))
    except Exception:  # a message that cannot even be printed
        message = "(message unavailable)"
    if len(message) > MAX_ERROR_CHARS:
        message = message[:MAX_ERROR_CHARS] + "..."
    name = type(error).__name__
    return f"program raised {name}: {message}{where}" if message else f"program raised {name}{where}"


def encodable(result: dict[str, Any]) -> dict[str, Any]:
    """The result with its text fields free of lone surrogates (the parent accepts only real text)."""
    return {key: clean_text(value) if isinstance(value, str) else value for key, value in result.items()}


def failure(kind: str, error: str) -> dict[str, Any]:
    return {"type": "result", "ok": False, "kind": kind, "error": error}


def compile_program(source: str, python_checks: bool) -> CodeType:
    """The program's code object; ProgramRejected says why it cannot be compiled, in plain words."""
    try:
        if not python_checks:  # test-only: the OS jail alone stands between the program and the host
            return compile(source, PROGRAM_FILENAME, "exec")
        tree = prepare_for_execution(validate_program(source), FORMAT_FUNCTION_NAME)
        return compile(tree, PROGRAM_FILENAME, "exec")
    except SyntaxError as error:
        raise ProgramRejected(f"syntax error at line {error.lineno}: {error.msg}") from None
    except (RecursionError, MemoryError):
        raise ProgramRejected("the program is nested too deeply to compile; simplify it") from None
    except ValueError as error:
        raise ProgramRejected(f"the program cannot be compiled: {error}") from None


def unchecked_globals(channel: PipeChannel, scene: Any) -> dict[str, Any]:
    """Test-only: real builtins and the real numpy module, as if every Python-level wall had fallen."""
    return {
        "__builtins__": builtins,
        "__name__": "program",
        "np": numpy,
        "numpy": numpy,
        "math": math,
        "pySpatial": PySpatial(channel, scene),
    }


def run_job(
    job: dict[str, Any], channel: PipeChannel, install_filter: Callable[[], None] | None
) -> dict[str, Any]:
    """Compile, limit, filter, hook, run. `install_filter` (the seccomp filter) is set in the jail."""
    jailed = install_filter is not None
    limits = job["limits"]
    python_checks = job.get("python_checks", True) is not False
    if not python_checks and not jailed:
        return failure("crash", "the Python-level checks may only be switched off inside the OS jail")
    capture = OutputCapture(int(limits["max_output_chars"]))
    try:
        code = compile_program(job["source"], python_checks)
    except ProgramRejected as error:
        return failure("rejected", f"rejected: {error}")
    scene = build_scene(int(job["num_images"]), str(job["question"]), channel)
    if python_checks:
        names = program_globals(capture, {"pySpatial": PySpatial(channel, scene)})
    else:
        names = unchecked_globals(channel, scene)
    apply_resource_limits(int(limits["cpu_seconds"]), int(limits["memory_mb"]), python_checks)
    if install_filter is not None:
        install_filter()
    if python_checks:
        arm_audit_hook(code)
    result = execute(code, names, scene, capture, limits)
    result["stdout"] = capture.text()
    return result


def execute(
    code: CodeType, names: dict[str, Any], scene: Any, capture: OutputCapture, limits: dict[str, Any]
) -> dict[str, Any]:
    try:
        exec(code, names)
        value = names["program"](scene)
        rendered = render_output(value, int(limits["max_output_chars"]), int(limits["max_images"]))
    except MemoryError:
        return failure("memory", f"memory limit exceeded ({limits['memory_mb']} MB)")
    except OutputLimitExceeded as error:
        return failure("output", str(error))
    except OutputTooLarge as error:
        return failure("output", f"output too large: {error}")
    except OutputRejected as error:
        return failure("output", f"output is not serializable: {error}")
    except BaseException as error:  # the program's own failure, reported to the code model
        return failure("exception", describe_exception(error))
    if capture.overflowed:
        return failure("output", f"the program printed more than {capture.max_chars} characters")
    return {"type": "result", "ok": True, "text": rendered.text, "images": rendered.image_ids}


def main(jailed: bool = False) -> None:
    die_with_parent()
    faulthandler.enable()  # a C-level crash leaves its cause and the program line on stderr
    # Warnings would only reach the discarded stderr, and showing one reads source files (refused).
    numpy.seterr(all="ignore")
    warnings.simplefilter("ignore")
    warm_up_numpy()
    install_filter = None
    if jailed:  # loaded now: libseccomp cannot be opened once RLIMIT_NOFILE is 0
        from services.agent.sandbox.seccomp_filter import install as install_filter
    reader, writer = take_protocol_streams()
    write_message(writer, {"type": "ready"})
    job = read_message(reader, MAX_INBOUND_BYTES)
    try:
        result = run_job(job, PipeChannel(reader, writer), install_filter)
    except MemoryError:
        result = failure("memory", "memory limit exceeded")
    except Exception as error:  # a bug of the sandbox itself, not of the program
        result = failure(
            "crash", f"the sandbox failed: {type(error).__name__}: {str(error)[:MAX_ERROR_CHARS]}"
        )
    write_message(writer, encodable(result))
    writer.close()
    os._exit(0)  # skip interpreter teardown: nothing of the program's may run after the result


if __name__ == "__main__":
    main()
