"""Recorded replies of a real code model through the parser, the demo-code clean-up and the validator.

    python -m bench.model_replies [--file tests/data/model_replies/qwen2.5-coder-1.5b-instruct-q4.jsonl]

For each reply: whether it held a program, what was dropped, and whether the validator accepts the
result; then the totals. Any JSONL with a `reply` field per line works (record your own model's).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from services.agent.codegen import find_program
from services.agent.program_cleanup import clean_program
from services.agent.sandbox.validation import ProgramRejected, validate_program

DEFAULT_FILE = Path("tests/data/model_replies/qwen2.5-coder-1.5b-instruct-q4.jsonl")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.model_replies", description=__doc__.split("\n")[0])
    parser.add_argument("--file", type=Path, default=DEFAULT_FILE)
    args = parser.parse_args(argv)
    rows = [json.loads(line) for line in args.file.read_text(encoding="utf-8").splitlines() if line.strip()]
    print(f"### {args.file.name}: {len(rows)} replies\n")
    print("| # | id | attempt | program | dropped lines | validator |")
    print("| ---: | --- | ---: | --- | ---: | --- |")
    accepted = without = 0
    for index, row in enumerate(rows):
        choice = find_program(row.get("reply") or "")
        if choice is None:
            without += 1
            print(f"| {index} | {row.get('id', '')} | {row.get('attempt', '')} | none | 0 | - |")
            continue
        cleaned = clean_program(choice.source)
        try:
            validate_program(cleaned.source)
            verdict = "accepted"
            accepted += 1
        except ProgramRejected as rejected:
            verdict = f"rejected: {str(rejected)[:80]}"
        label = f"| {index} | {row.get('id', '')} | {row.get('attempt', '')}"
        print(f"{label} | yes | {len(cleaned.dropped)} | {verdict} |")
    rejected_count = len(rows) - accepted - without
    print(f"\naccepted {accepted} of {len(rows)}; without a program {without}; rejected {rejected_count}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
