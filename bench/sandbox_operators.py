"""What routing a program's operators and numpy calls through the sandbox's checks costs (issue 38).

    python -m bench.sandbox_operators [--repo PATH] [--repeats 5]

Three programs, compiled as the worker compiles them (validated, rewritten) and run in this process
with the program's real globals, against the same source compiled as written (no rewriting: the
operators run bare, numpy calls still go through the `np` stand-in). `--repo` imports the sandbox
from another checkout (e.g. main, before issue 38) to time its rewriting the same way.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time

import numpy

PROGRAMS = {
    "arithmetic loop (2M operators)": (
        "def program(input_scene):\n"
        "    total = 0\n"
        "    for i in range(1_000_000):\n"
        "        total = total + i * 2\n"
        "    return total\n"
    ),
    "pose geometry (numpy operators, 20k)": (
        "def program(input_scene):\n"
        "    R = np.eye(3)\n"
        "    t = np.array([0.5, 0.0, 1.0])\n"
        "    acc = np.zeros(3)\n"
        "    for _ in range(10_000):\n"
        "        acc = acc + (-R.T @ t)\n"
        "    return float(acc.sum())\n"
    ),
    "numpy calls (30k)": (
        "def program(input_scene):\n"
        "    v = np.array([3.0, 4.0, 0.0])\n"
        "    out = 0.0\n"
        "    for _ in range(10_000):\n"
        "        out += float(np.linalg.norm(v)) + float(np.degrees(np.arctan2(v[1], v[0])))\n"
        "    return out\n"
    ),
}


def best_run(code: object, names: dict, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        scope = dict(names)
        exec(code, scope)
        started = time.perf_counter()
        scope["program"](None)
        times.append(time.perf_counter() - started)
    return min(times)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bench.sandbox_operators", description=__doc__.splitlines()[0])
    parser.add_argument("--repo", help="import the sandbox from this checkout instead")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    if args.repo:
        sys.path.insert(0, args.repo)
    builtins = importlib.import_module("services.agent.sandbox.builtins")
    validation = importlib.import_module("services.agent.sandbox.validation")
    print(f"sandbox from {builtins.__file__.rsplit('/services/', 1)[0]}, best of {args.repeats}")
    names = builtins.program_globals(builtins.OutputCapture(1000), {})
    for source in PROGRAMS.values():  # numpy imports parts of itself on first use, as in the worker
        scope = {"np": numpy, "range": lambda _: range(1)}
        exec(source, scope)
        scope["program"](None)
    for label, source in PROGRAMS.items():
        tree = validation.prepare_for_execution(
            validation.validate_program(source), builtins.FORMAT_FUNCTION_NAME
        )
        bare = best_run(compile(source, "<program>", "exec"), names, args.repeats)
        checked = best_run(compile(tree, "<program>", "exec"), names, args.repeats)
        print(f"  {label:38} as written {bare:6.3f} s   rewritten {checked:6.3f} s   x{checked / bare:4.1f}")


if __name__ == "__main__":
    main()
