"""Recorded replies of a real code model through the parser, the demo-code clean-up and the validator.

    python -m bench.model_replies [--file tests/data/model_replies/qwen2.5-coder-1.5b-instruct-q4.jsonl]

For each reply: whether it held a program, what was dropped, and whether the validator accepts the
result; then the totals, and how many programs reached, as the model wrote them, for something the
sandbox does not have (the "Not available" block of the code prompt names each of these kinds).
Any JSONL with a `reply` field per line works (record your own model's).
"""

from __future__ import annotations

import argparse
import ast
import collections
import json
from pathlib import Path

from services.agent.codegen import find_program
from services.agent.program_cleanup import clean_program
from services.agent.sandbox.validation import ProgramRejected, validate_program

DEFAULT_FILE = Path("tests/data/model_replies/qwen2.5-coder-1.5b-instruct-q4.jsonl")
AVAILABLE_MODULES = {"numpy", "math"}
OS_MODULES = {"os", "sys", "subprocess", "shutil", "pathlib", "glob"}
NETWORK_MODULES = {"requests", "urllib", "socket", "http", "httpx", "aiohttp"}
FILE_CALLS = {"open", "imread", "imwrite", "load", "save", "savefig", "read", "write", "listdir"}
FILE_SUFFIXES = (".jpg", ".jpeg", ".png", ".txt", ".json", ".npy", ".ply", ".csv")
# Each kind, and the words of the prompt's "Not available" block that name it.
UNAVAILABLE_KINDS = {
    "imports": "imports other than",
    "files": "files",
    "network": "the network",
    "os": "the operating system",
    "classes": "`class` definitions",
    "underscores": "starting with `_`",
}


def _module_kinds(module: str) -> set[str]:
    root = module.split(".")[0]
    if root in AVAILABLE_MODULES:
        return set()
    kinds = {"imports"}
    kinds |= {"os"} if root in OS_MODULES else set()
    kinds |= {"network"} if root in NETWORK_MODULES else set()
    return kinds


def unavailable_uses(source: str) -> set[str]:
    """The kinds of things `source` reaches for that the sandbox does not have (UNAVAILABLE_KINDS)."""
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError):
        return set()
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                found |= _module_kinds(alias.name)
        elif isinstance(node, ast.ImportFrom):
            found |= _module_kinds(node.module or "")
        elif isinstance(node, ast.ClassDef):
            found.add("classes")
        elif isinstance(node, ast.Name | ast.Attribute):
            name = node.id if isinstance(node, ast.Name) else node.attr
            if name.startswith("_") and name != "_":
                found.add("underscores")
            if name in OS_MODULES:
                found.add("os")
        if isinstance(node, ast.Call):
            function = node.func
            name = function.id if isinstance(function, ast.Name) else getattr(function, "attr", "")
            if name in FILE_CALLS:
                found.add("files")
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            if node.value.lower().endswith(FILE_SUFFIXES) or "path/to" in node.value:
                found.add("files")
    return found


def tally_unavailable(rows: list[dict]) -> collections.Counter:
    """How many replies' programs (as written, before the clean-up) reach for each kind."""
    counts: collections.Counter = collections.Counter()
    for row in rows:
        choice = find_program(row.get("reply") or "")
        if choice is not None:
            counts.update(unavailable_uses(choice.source))
    return counts


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
    counts = tally_unavailable(rows)
    print("\nprograms reaching, as written, for what the sandbox does not have (before the clean-up):")
    for kind in UNAVAILABLE_KINDS:
        print(f"- {kind}: {counts[kind]} of {len(rows)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
