"""Trace the jailed sandbox worker with strace and list the syscalls it makes after its seccomp filter
is loaded: the method behind seccomp_filter.ALLOWED (docs/ARCHITECTURE.md, "The seccomp allow-list").

    python scripts/trace_sandbox_syscalls.py [--out /tmp/pyspatial-trace] [--check]

As root (strace follows bubblewrap into its namespaces). The benign corpus is run under pytest in
this process with every jailed worker started as `strace -f -o FILE bwrap ...`:
- tests/test_sandbox.py (what real programs do: tools, images, prints, numpy, errors);
- tests/test_sandbox_attacks.py behind both layers (the worker's own failure paths: memory errors,
  output limits, rejected programs, caught exceptions; the Python layer stops each attack first);
- the machinery probe below, with the Python checks off: the imports and read-only file reads of the
  jailed interpreter itself (a read-only view of the interpreter and libraries), plus threads, so
  that the OS layer alone can be tested with real attack programs.
For each trace the worker's process is the one that calls seccomp(SECCOMP_SET_MODE_FILTER); every
syscall it (and every thread started after that) makes from then on is counted. The filter under
trace is the allow-list itself, so a run with `--check` fails when a traced syscall is refused
(strace shows `= -1 EPERM` for a syscall the list lacks); it also names ALLOWED entries no trace used.
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

MACHINERY_PROBE = """
import os, socket, subprocess, ctypes, threading, resource, mmap, signal, json
def program(input_scene):
    facts = [os.getuid(), os.getgid(), os.getpid(), os.getppid(), os.getcwd(), os.listdir("/tmp"),
             os.path.exists("/etc"), open("/proc/self/status").read()[:10], os.listdir("/proc/self/fd")]
    t = threading.Thread(target=print)
    t.start()
    t.join()
    return str(len(facts))
"""
FILTER_LOADED = re.compile(r"^(\d+)\s+seccomp\(SECCOMP_SET_MODE_FILTER, [^,]*, \{len=.*\) = 0")
CALL = re.compile(r"^(\d+)\s+(?:<\.\.\. (\w+) resumed>|(\w+)\()")
REFUSED = re.compile(r"^(\d+)\s+(\w+)\(.*= -1 (EPERM|ENOSYS)")


def parse(trace: str) -> tuple[collections.Counter, set[str]]:
    """(syscall -> count after the filter, syscalls answered EPERM/ENOSYS after it) of one trace."""
    counted: collections.Counter = collections.Counter()
    refused: set[str] = set()
    watched: set[str] = set()
    seen_before: set[str] = set()
    for line in trace.splitlines():
        loaded = FILTER_LOADED.match(line)
        if loaded:
            watched.add(loaded.group(1))
            continue
        call = CALL.match(line)
        if not call:
            continue
        pid, name = call.group(1), call.group(2) or call.group(3)
        if not watched:
            seen_before.add(pid)
        elif pid not in seen_before:
            watched.add(pid)  # the worker, or a thread it started after the filter
        if pid in watched:
            counted[name] += 1
            failed = REFUSED.match(line)
            if failed:
                refused.add(f"{name} ({failed.group(3)})")
    return counted, refused


def run_corpus(out: Path) -> None:
    import pytest

    from services.agent.sandbox import jail

    original = jail.jailed_worker_command
    strace = shutil.which("strace")
    if strace is None:
        raise SystemExit("strace is not installed: apt-get install -y strace")
    counter = iter(range(1 << 30))

    def traced() -> list[str]:
        return [
            strace,
            "-f",
            "-qq",
            "-o",
            str(out / f"worker-{os.getpid()}-{next(counter)}.trace"),
            *original(),
        ]

    jail.jailed_worker_command = traced
    probe_file = out / "test_machinery_probe.py"
    probe_file.write_text(
        "from services.agent.sandbox import SandboxLimits, run_program\n"
        "from tests.test_sandbox_attacks import TinyTools\n"
        f"SOURCE = {MACHINERY_PROBE!r}\n"
        "def test_machinery() -> None:\n"
        "    limits = SandboxLimits(wall_seconds=60)\n"
        "    result = run_program(SOURCE, 'q', 2, TinyTools(), limits, python_checks=False)\n"
        "    assert result.ok, result.error\n"
    )
    selection = [
        "tests/test_sandbox.py",
        "tests/test_sandbox_attacks.py",
        "-k",
        "not python_alone and not per_program_overhead and not cpu_bomb",
        str(probe_file),
    ]
    pytest.main(["-q", "-p", "no:cacheprovider", "--rootdir", str(ROOT), *selection])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=Path, default=None, help="folder for the traces (default: a new temp one)"
    )
    parser.add_argument("--check", action="store_true", help="fail on refused or unused allow-list entries")
    args = parser.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp(prefix="pyspatial-trace-"))
    out.mkdir(parents=True, exist_ok=True)
    os.chdir(ROOT)
    run_corpus(out)
    total: collections.Counter = collections.Counter()
    refused: set[str] = set()
    traces = sorted(out.glob("*.trace"))
    for path in traces:
        counted, failed = parse(path.read_text(errors="replace"))
        total.update(counted)
        refused |= failed
    print(f"\n{len(traces)} worker traces in {out}; {len(total)} syscalls after the filter:")
    print(", ".join(f'"{name}"' for name in sorted(total)))
    print(
        "refused after the filter (expected only from attack programs):", ", ".join(sorted(refused)) or "none"
    )
    if not args.check:
        return 0
    from services.agent.sandbox.seccomp_filter import ALLOWED, CONDITIONAL, MARGIN

    missing = sorted(set(total) - set(ALLOWED + MARGIN + CONDITIONAL))
    unused = sorted(set(ALLOWED) - set(total))
    print("traced but not on the list:", missing or "none")
    print("on ALLOWED but never traced:", unused or "none")
    print("MARGIN (reasoned, untraced):", ", ".join(MARGIN), "; CONDITIONAL:", ", ".join(CONDITIONAL))
    return 1 if missing else 0


if __name__ == "__main__":
    raise SystemExit(main())
