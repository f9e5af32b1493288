"""`pyspatial bench NAME [ARGS...]`: run `bench.<NAME>.main(args)` for a module in bench/."""

from __future__ import annotations

import ast
import importlib
import inspect
from pathlib import Path

import typer

import bench as bench_package
from cli.console import fail


def available_benches() -> dict[str, str]:
    """Bench modules that define main(), with the first line of their docstring.

    Read with ast, not imported: benches load heavy libraries (torch, open3d) that `--help`
    should not pay for.
    """
    found = {}
    modules = sorted(path for folder in bench_package.__path__ for path in Path(folder).glob("*.py"))
    for path in modules:
        if path.stem.startswith("_"):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if not any(isinstance(node, ast.FunctionDef) and node.name == "main" for node in tree.body):
            continue
        summary = (ast.get_docstring(tree) or "").strip().splitlines()
        found[path.stem] = summary[0] if summary else ""
    return found


def _listing() -> str:
    benches = available_benches()
    if not benches:
        return "No benches in bench/ yet."
    lines = [f"{name}: {summary}" if summary else name for name, summary in benches.items()]
    return "Available benches:\n\n" + "\n\n".join(lines)


def bench(
    ctx: typer.Context,
    name: str = typer.Argument(..., help="Bench module in bench/ (see the list below)."),
) -> None:
    benches = available_benches()
    if name not in benches:
        raise fail(f"unknown bench {name!r}; available: {', '.join(benches) or 'none'}")
    main = importlib.import_module(f"bench.{name}").main
    # Benches take their argument list the way argparse does; pass what followed NAME untouched.
    outcome = main(list(ctx.args)) if inspect.signature(main).parameters else main()
    raise typer.Exit(outcome if isinstance(outcome, int) else 0)


bench.__doc__ = "Run a benchmark: bench.NAME.main(ARGS). " + _listing()
