"""Run untrusted generated programs: `def program(input_scene): ...` against the pySpatial API.

Four walls in depth (tests/test_sandbox_attacks.py, test_sandbox_jail.py and test_sandbox_http.py
hold each of them to account):

0. jail.py / seccomp_filter.py: the OS jail, independent of everything below. The worker runs under
   bubblewrap in its own PID, network (empty), IPC, UTS and mount namespaces with a read-only view
   of only the interpreter, site-packages and this package, as uid 65534 without capabilities,
   with no-new-privs, dying with its parent, behind a seccomp allow-list (default EPERM; traced over
   the benign corpus: scripts/trace_sandbox_syscalls.py) that leaves out new processes, exec,
   signals to others, sockets, sessions, mounts, writable opens, SysV IPC, memfds and pipes.
   No jail, no programs (unless the operator opts out with PYSPATIAL_SANDBOX_JAIL=off).
1. validation.py checks the syntax tree before anything runs (own AST checker rather than
   RestrictedPython: the allowed language is tiny, so rejecting outright is simpler than
   RestrictedPython's rewrite-and-guard model, needs no guard functions to get right, and gives the
   code model one plain message per problem to repair). No imports (but `import numpy as np`,
   `import math` and `from math import atan2` are accepted and bound to the stand-ins), no classes,
   no `global`/`yield`/async/`with`, no name or attribute starting with `_` (except the name `_`),
   no frame/generator/code attributes, no file, pickle or raw-memory attributes of numpy, no
   attribute writes. `x.format(...)`, f-string fields and `%` are rewritten to formatters that
   refuse `{0.attr}` / `{0[key]}` fields and hide heap addresses.
2. builtins.py: the program's globals hold only whitelisted builtins, a captured `print`, a bounded
   `range`, a read-only numpy stand-in (`np`: functions that build new arrays; `np.ndarray` only for
   isinstance) and `math`. Every attribute a program reads passes numpy_surface.attribute: numpy
   arrays, scalars and dtypes offer only an allow-list of read-only and arithmetic members (no
   in-place or raw-memory method). Every numpy callable takes only the arguments it lists (no
   `out=`, `where=`, `signature=`...), and only numeric dtypes go in or come out, of the callables,
   the operators (operators.py) and the arithmetic builtins alike.
3. worker.py runs the program in a fresh `python -I` process (one per run) with an empty
   environment, RLIMIT_CPU / AS / FSIZE=0 / NOFILE=0 / CORE=0 / NPROC=32, an audit hook refusing
   open / import / exec / os / socket / subprocess events, and stdin/stdout replaced by /dev/null
   (the protocol uses private copies of the pipes, so prints cannot forge messages). numpy's lazily
   initialised paths are warmed up before the hook is armed. The parent enforces the wall-clock
   limit, bounds every message it reads, and kills the whole process group.

The program never sees files or the network: reconstruction, camera-motion sentences, rendering and
input images are requests to the parent (runner.py), which serves them through a `ToolProvider`
and keeps every pixel; the program holds opaque `Image` handles. Pose tools (shared.geometry.poses) run
locally in the child. Time spent in the parent's tools counts against `wall_seconds`, and the
number of calls against `max_tool_calls`: a loop of cheap calls ends at either.
"""

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from services.agent.sandbox.runner import ToolProvider, run_program
    from services.agent.sandbox.validation import ProgramRejected, validate_program
    from services.agent.sandbox.worker_process import ExecutionResult, SandboxLimits

_EXPORTS = {
    "ExecutionResult": "worker_process",
    "SandboxLimits": "worker_process",
    "ToolProvider": "runner",
    "run_program": "runner",
    "ProgramRejected": "validation",
    "validate_program": "validation",
}


def __getattr__(name: str):  # noqa: ANN202
    """Lazy exports: the worker imports this package too, and needs none of the parent's modules."""
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)


__all__ = [
    "ExecutionResult",
    "ProgramRejected",
    "SandboxLimits",
    "ToolProvider",
    "run_program",
    "validate_program",
]
