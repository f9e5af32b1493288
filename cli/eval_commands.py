"""`pyspatial eval ...`: benchmark harnesses (MindCube, Omni3D-Bench, answer-model baseline).

Every command writes one JSON line per item to --out as soon as the item is done; --resume skips
the ids already there, so an interrupted run continues where it stopped.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer

from cli.api_keys import agent_key_option, recon_key_option
from cli.console import explain_service_error
from evaluation.dataset import DatasetError, default_image_root, read_mindcube
from evaluation.metrics import summarize_mindcube
from evaluation.mindcube import MINDCUBE_INSTRUCTION, evaluate_mindcube
from evaluation.mmsi import RecordedReplies, evaluate_mmsi, fetch_parquet, read_mmsi
from evaluation.omni3d import OMNI3D_INSTRUCTION, evaluate_omni3d
from evaluation.report import mindcube_report, mmsi_table, omni3d_report, report_console
from evaluation.runner import read_results
from evaluation.solvers import BaselineSolver, NoAnswerModel, answer_model_config, pyspatial_solver
from services.agent.llm import ChatClient
from shared.wire.client import ServiceError
from shared.wire.settings import DEFAULT_AGENT_PORT, DEFAULT_RECON_PORT, AgentSettings

eval_app = typer.Typer(help="Run benchmarks against the services and print the paper's tables.")
console = report_console()

JsonlOption = Annotated[
    Path, typer.Option("--jsonl", exists=True, dir_okay=False, help="Benchmark questions (JSONL).")
]
ImageRootOption = Annotated[
    Path, typer.Option("--image-root", exists=True, file_okay=False, help="Image paths are relative to it.")
]
MindCubeRootOption = Annotated[
    Path | None,
    typer.Option(
        "--image-root",
        exists=True,
        file_okay=False,
        help="Image paths are relative to it; default: MindCube's layout, the folder above data/raw/ "
        "when the JSONL is in one, else the JSONL's folder.",
    ),
]
LimitOption = Annotated[int | None, typer.Option("--limit", min=1, help="Only the first N items.")]
ConcurrencyOption = Annotated[int, typer.Option("--concurrency", min=1, help="Items in flight at once.")]
ResumeOption = Annotated[bool, typer.Option("--resume", help="Skip the ids already in --out.")]
ProgressOption = Annotated[bool, typer.Option("--progress/--no-progress", help="Show a progress bar.")]
AgentUrlOption = Annotated[
    str, typer.Option("--agent-url", envvar="PYSPATIAL_AGENT_URL", help="The agent service.")
]
ReconUrlOption = Annotated[
    str,
    typer.Option(
        "--recon-url",
        envvar="PYSPATIAL_RECON_URL",
        help="The recon service, for uploading exact cameras and depth with --backbone posed-rgbd.",
    ),
]
BackboneOption = Annotated[
    str | None,
    typer.Option(
        "--backbone",
        help="classical, posed-rgbd or vggt. With posed-rgbd, items whose meta_info names a scene file "
        "with exact cameras and depth (the synthetic generator writes them) are uploaded with those first.",
    ),
]

AgentKeyOption = Annotated[str | None, agent_key_option(annotated=True)]
ReconKeyOption = Annotated[str | None, recon_key_option("--recon-api-key", annotated=True)]

DEFAULT_AGENT_URL = f"http://127.0.0.1:{DEFAULT_AGENT_PORT}"
DEFAULT_RECON_URL = f"http://127.0.0.1:{DEFAULT_RECON_PORT}"


def _fail(message: str) -> typer.Exit:
    console.print(f"[red]error:[/red] {message}")
    return typer.Exit(code=2)


@contextmanager
def _failing_clearly() -> Iterator[None]:
    """A bad dataset or an unreachable service ends the command with its message (exit 2)."""
    try:
        yield
    except DatasetError as error:
        raise _fail(str(error)) from error
    except ServiceError as error:
        raise _fail(explain_service_error(error)) from error


@eval_app.command("mindcube")
def mindcube(
    jsonl: JsonlOption,
    image_root: MindCubeRootOption = None,
    limit: LimitOption = None,
    concurrency: ConcurrencyOption = 4,
    out: Annotated[Path, typer.Option("--out", help="Results, one JSON line per item.")] = Path(
        "mindcube_results.jsonl"
    ),
    resume: ResumeOption = False,
    agent_url: AgentUrlOption = DEFAULT_AGENT_URL,
    backbone: BackboneOption = None,
    recon_url: ReconUrlOption = DEFAULT_RECON_URL,
    progress: ProgressOption = True,
    api_key: AgentKeyOption = None,
    recon_api_key: ReconKeyOption = None,
) -> None:
    """Answer MindCube questions with pySpatial (POST /v1/solve) and print accuracy by setting.

    Items with a missing image are skipped with a warning. The results file has MindCube's fields
    (``answer``, ``gt_answer``), so MindCube's own evaluator reads it unchanged. Accuracy is printed
    over all items (MindCube's denominator) and over answered items (the paper's code's).
    """
    image_root = image_root or default_image_root(jsonl)
    with _failing_clearly():
        with pyspatial_solver(agent_url, image_root, backbone, recon_url, api_key, recon_api_key) as solver:
            run = evaluate_mindcube(
                jsonl, image_root, solver.solve, out, limit, concurrency, resume, console, progress
            )
    console.print(mindcube_report([run.summary]))
    if run.skipped:
        console.print(f"{len(run.skipped)} item(s) skipped: their images are missing (warnings above)")
    console.print(f"results: {out}")


@eval_app.command("omni3d")
def omni3d(
    jsonl: JsonlOption,
    image_root: ImageRootOption,
    limit: LimitOption = None,
    concurrency: ConcurrencyOption = 4,
    out: Annotated[Path, typer.Option("--out", help="Results, one JSON line per item.")] = Path(
        "omni3d_results.jsonl"
    ),
    resume: ResumeOption = False,
    agent_url: AgentUrlOption = DEFAULT_AGENT_URL,
    backbone: BackboneOption = None,
    progress: ProgressOption = True,
    api_key: AgentKeyOption = None,
) -> None:
    """Answer Omni3D-Bench questions with pySpatial: exact match and mean relative accuracy.

    The agent answers with option letters; for these free-form questions its answer text and
    reasoning are parsed for the value (see evaluation/omni3d.py for what that means for scores).
    """
    with _failing_clearly():
        with pyspatial_solver(agent_url, image_root, backbone, api_key=api_key) as solver:
            run = evaluate_omni3d(
                jsonl, image_root, solver.solve, out, limit, concurrency, resume, console, progress
            )
    console.print(omni3d_report([run.summary]))
    console.print(f"results: {out}")


@eval_app.command("baseline")
def baseline(
    jsonl: JsonlOption,
    image_root: ImageRootOption,
    benchmark: Annotated[
        str, typer.Option("--benchmark", help="mindcube or omni3d: the JSONL's format.")
    ] = "mindcube",
    limit: LimitOption = None,
    concurrency: ConcurrencyOption = 4,
    out: Annotated[Path, typer.Option("--out", help="Results, one JSON line per item.")] = Path(
        "baseline_results.jsonl"
    ),
    resume: ResumeOption = False,
    model: Annotated[
        str | None, typer.Option("--model", help="Answer model; PYSPATIAL_ANSWER_MODEL when unset.")
    ] = None,
    compare: Annotated[
        Path | None,
        typer.Option(
            "--compare",
            exists=True,
            dir_okay=False,
            help="A pySpatial results file of the same items (from `eval mindcube`): adds its row.",
        ),
    ] = None,
    progress: ProgressOption = True,
) -> None:
    """The same questions answered by the answer model alone (no program, no 3D tools)."""
    if benchmark not in ("mindcube", "omni3d"):
        raise _fail(f"--benchmark must be mindcube or omni3d, not {benchmark!r}")
    try:
        config = answer_model_config(AgentSettings(), model)
    except NoAnswerModel as error:
        raise _fail(str(error)) from error
    try:
        with ChatClient(config) as chat:
            if benchmark == "omni3d":
                solver = BaselineSolver(chat, OMNI3D_INSTRUCTION)
                run = evaluate_omni3d(
                    jsonl, image_root, solver.solve, out, limit, concurrency, resume, console, progress
                )
                console.print(omni3d_report([run.summary], title="Omni3D-Bench: answer model alone"))
                return
            solver = BaselineSolver(chat, MINDCUBE_INSTRUCTION)
            items = read_mindcube(jsonl, image_root, limit)
            run = evaluate_mindcube(
                jsonl, image_root, solver.solve, out, limit, concurrency, resume, console, progress, items
            )
    except DatasetError as error:
        raise _fail(str(error)) from error
    rows = [run.summary]
    if compare is not None:
        # Only the compared file's records of these same items, so both rows count the same questions.
        ids = {item.id for item in items}
        rows.append(summarize_mindcube([r for r in read_results(compare) if r["id"] in ids]))
    console.print(
        mindcube_report(rows, title="MindCube accuracy (%): the answer model alone and with pySpatial")
    )
    console.print(f"results: {out}")


@eval_app.command("mmsi")
def mmsi(
    parquet: Annotated[
        Path | None,
        typer.Option("--parquet", exists=True, dir_okay=False, help="A local MMSI_Bench.parquet."),
    ] = None,
    fetch: Annotated[
        bool, typer.Option("--fetch", help="Get MMSI_Bench.parquet from the hub (RunsenXu/MMSI-Bench).")
    ] = False,
    types: Annotated[
        list[str] | None,
        typer.Option("--types", help="Only these question types (repeat, or comma-separated)."),
    ] = None,
    circular: Annotated[
        bool,
        typer.Option(
            "--circular", help="Ask each question once per rotation of its options; all must be right."
        ),
    ] = False,
    replies: Annotated[
        Path | None,
        typer.Option(
            "--replies", exists=True, dir_okay=False, help="Score recorded replies (JSONL id, reply)."
        ),
    ] = None,
    limit: LimitOption = None,
    concurrency: ConcurrencyOption = 4,
    out: Annotated[Path, typer.Option("--out", help="Predictions, one JSON line per question.")] = Path(
        "mmsi_results.jsonl"
    ),
    resume: ResumeOption = False,
    agent_url: AgentUrlOption = DEFAULT_AGENT_URL,
    backbone: BackboneOption = None,
    progress: ProgressOption = True,
    api_key: AgentKeyOption = None,
) -> None:
    """Answer MMSI-Bench with pySpatial (POST /v1/solve), or score recorded replies, per question type.

    Both the project's extractor and MMSI-Bench's published one score every reply; the summary is
    printed and written next to --out (.summary.json).
    """
    if (parquet is None) == (not fetch):
        raise _fail("give exactly one of --parquet PATH or --fetch")
    wanted = [name.strip() for value in types or [] for name in value.split(",") if name.strip()] or None
    with _failing_clearly():
        source = parquet if parquet is not None else fetch_parquet()
        items = read_mmsi(source, out.parent / f"{out.stem}_images", limit, wanted)
        if replies is not None:
            records, summary = evaluate_mmsi(
                items, RecordedReplies(replies).solve, out, circular, concurrency, resume, console, progress
            )
        else:
            with pyspatial_solver(agent_url, out.parent, backbone, api_key=api_key) as solver:
                records, summary = evaluate_mmsi(
                    items, solver.solve, out, circular, concurrency, resume, console, progress
                )
    console.print(mmsi_table(summary))
    summary_path = out.with_suffix(".summary.json")
    summary_path.write_text(json.dumps(summary.as_dict(), indent=2) + "\n", encoding="utf-8")
    console.print(f"results: {out} ({len(records)} predictions); summary: {summary_path}")
