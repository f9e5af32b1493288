"""What the sandbox protocol's depth check costs on hostile frames, before and after issue 38.

    python -m bench.protocol_parse [--repeats 3] [--old-max-kb 40]

Frames at the parent's size limit for the default limits (24 x max_output_chars + 1 MiB): a string
that never closes ('"' then N times '\\"', the frame that made the old check quadratic), brackets
only, a realistic result (one long text) and a realistic tool reply (numbers). For each: the new
`nesting_depth` and the whole `decode_message` (depth check, then json.loads). The old check (the
backtracking regex, kept here as it was) is timed on the same frames, except the unterminated
string, which it meets only at a few small sizes: its time grows with the square of the size, and
the figure at the size limit is that growth extrapolated.
"""

from __future__ import annotations

import argparse
import json
import re
import time
from collections.abc import Callable

from services.agent.sandbox.protocol import MAX_NESTING, ProtocolError, decode_message, nesting_depth
from services.agent.sandbox.worker_process import SandboxLimits

FRAME_LIMIT = 24 * SandboxLimits().max_output_chars + (1 << 20)
_OLD_BRACKETS = re.compile(rb'[\[\]{}]|"(?:[^"\\]|\\.)*"')


def old_nesting_depth(line: bytes) -> int:
    """The depth check before issue 38: one regex over brackets and strings (backtracking)."""
    depth = deepest = 0
    for match in _OLD_BRACKETS.finditer(line):
        token = match.group()
        if token in (b"[", b"{"):
            depth += 1
            deepest = max(deepest, depth)
            if deepest > MAX_NESTING:
                break
        elif token in (b"]", b"}"):
            depth -= 1
    return deepest


def unterminated(size: int) -> bytes:
    return b'"' + b'\\"' * ((size - 1) // 2)


def frames(size: int) -> dict[str, bytes]:
    text = {"type": "result", "ok": True, "text": "x" * (size - 80), "images": [], "stdout": ""}
    row = [0.123456789, -2.5, 3.0]
    reply = {"type": "reply", "ok": True, "value": [row] * ((size - 60) // len(json.dumps(row)))}
    return {
        "unterminated string": unterminated(size),
        "brackets only": b"[]" * (size // 2),
        "result text": json.dumps(text, separators=(",", ":")).encode(),
        "reply of numbers": json.dumps(reply, separators=(",", ":")).encode(),
    }


def best_of(repeats: int, function: Callable[[bytes], object], frame: bytes) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        try:
            function(frame)
        except ProtocolError:
            pass
        times.append(time.perf_counter() - started)
    return min(times)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bench.protocol_parse", description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="runs per figure (the best is kept)")
    parser.add_argument(
        "--old-max-kb", type=int, default=40, help="largest unterminated frame for the old check"
    )
    args = parser.parse_args(argv)
    print(f"frames of {FRAME_LIMIT} bytes (the size limit), best of {args.repeats}")
    print(f"{'frame':22} {'old depth check':>16} {'new depth check':>16} {'decode_message':>15}")
    for name, frame in frames(FRAME_LIMIT).items():
        new = best_of(args.repeats, nesting_depth, frame)
        whole = best_of(args.repeats, decode_message, frame)
        old = (
            "see below" if name == "unterminated string" else f"{best_of(1, old_nesting_depth, frame):.3f} s"
        )
        print(f"{name:22} {old:>16} {new:>14.3f} s {whole:>13.3f} s")
    print("the unterminated string, old check, by size:")
    sizes = [kb * 1024 for kb in (args.old_max_kb // 4, args.old_max_kb // 2, args.old_max_kb)]
    seconds = [best_of(1, old_nesting_depth, unterminated(size)) for size in sizes]
    for size, taken in zip(sizes, seconds, strict=True):
        new = best_of(args.repeats, nesting_depth, unterminated(size))
        print(f"  {size // 1024:4d} KB: {taken:8.2f} s (new: {new:.4f} s)")
    extrapolated = seconds[-1] * (FRAME_LIMIT / sizes[-1]) ** 2
    print(f"  at the size limit, extrapolated (x size squared): {extrapolated / 3600:.1f} hours")


if __name__ == "__main__":
    main()
