"""A real code model on synthetic MindCube-style questions, next to the offline planner on the same ones.

    PYSPATIAL_CODE_MODEL=qwen2.5-coder PYSPATIAL_CODE_MODEL_BASE_URL=http://127.0.0.1:8080/v1 \
    PYSPATIAL_CODE_MODEL_TEXT_ONLY=true python -m bench.real_model --questions 24

The model is whatever OpenAI-compatible endpoint the environment names (llama.cpp / llama-cpp-python
server, vLLM, Ollama, a hosted API): every PYSPATIAL_* agent setting is read as the agent reads it
(code and answer model, keys, text-only, max tokens, repairs). The bench renders the questions
(shared/synthetic: exact cameras and depth, posed-rgbd backbone, so geometry is not what is being
measured), starts a recon service and two agents, one with the configured models and one with
neither (offline planner and answerer), and asks both every question.

Per system: attempts; how many replies held a program (parsed), passed the validator (validated),
ran without an exception (ran); repairs; fallbacks to the planner; questions answered and answered
correctly, and of those correct how many came from a model-written program (before any fallback);
mean seconds per stage; tokens per stage. Then the error kinds of failed attempts, per question
family the answered / correct counts of both systems, and one row per question (program source,
repairs, answer, truth). By default only text-clue questions (self-movement: the clue is a camera-
motion sentence, which a text-only model can read) are asked; `--all-families` asks all of them.

`--record FILE` keeps every code-model reply in the order the model was asked (JSON), so a test
replays the run through the scripted server without the model (tests/test_live_replay.py).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import math
import tempfile
import time
import uuid
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from evaluation.dataset import BenchmarkItem, read_mindcube
from evaluation.exact_scenes import ExactSceneUploader
from shared.local.services import running_service
from shared.questions.choices import read_choice
from shared.synthetic import make_dataset
from shared.wire.client import AgentClient, ReconClient, ServiceError, ServiceUnreachable
from shared.wire.schemas import SolveResponse
from shared.wire.settings import AgentSettings

QUESTIONS_PER_SCENE = 4
STAGES = ("codegen_ms", "execution_ms", "answering_ms", "total_ms")
# Offline agent: the model settings blanked, whatever the environment says.
OFFLINE_ENV = {"PYSPATIAL_CODE_MODEL": "", "PYSPATIAL_ANSWER_MODEL": ""}


@dataclass
class SystemRun:
    label: str
    responses: list[SolveResponse | None] = field(default_factory=list)
    errors: list[str | None] = field(default_factory=list)
    correct: list[bool] = field(default_factory=list)
    wall_s: float = 0.0

    def add(self, response: SolveResponse | None, error: str | None, truth: str | None) -> None:
        self.responses.append(response)
        self.errors.append(error)
        self.correct.append(response is not None and response.answer is not None and response.answer == truth)

    @property
    def answered(self) -> list[bool]:
        return [r is not None and r.answer is not None for r in self.responses]

    def row(self) -> dict[str, object]:
        done = [r for r in self.responses if r is not None]
        attempts = [a for r in done for a in r.attempts]
        model_attempts = [a for a in attempts if a.reply is not None]  # the planner's have no reply
        parsed = [a for a in model_attempts if a.program is not None]
        validated = [a for a in parsed if a.error_kind not in ("rejected", "repeated")]
        ran = [a for a in validated if a.error is None or a.error_kind == "not_evidence"]
        stage_s = {
            stage: (sum(getattr(r.timings, stage) for r in done) / len(done) / 1000.0) if done else None
            for stage in STAGES
        }
        return {
            "system": self.label,
            "questions": len(self.responses),
            "failed requests": sum(error is not None for error in self.errors),
            "attempts": len(attempts),
            "parsed": len(parsed),
            "validated": len(validated),
            "ran": len(ran),
            "repairs": sum(max(0, len([a for a in r.attempts if a.reply is not None]) - 1) for r in done),
            "fallbacks": sum(r.code_model_fallback is not None for r in done),
            "answered": sum(self.answered),
            "correct": sum(self.correct),
            "wrong": sum(self.answered) - sum(self.correct),
            # correct answers whose program the code model wrote (first or repaired), before any fallback
            "correct by model's program": sum(
                ok and r is not None and r.program_source in ("model", "repaired-model")
                for ok, r in zip(self.correct, self.responses, strict=True)
            ),
            "planner fallbacks": sum(
                r is not None and r.program_source == "planner" and r.code_model_fallback is not None
                for r in self.responses
            ),
            **{f"{stage.removesuffix('_ms')} s": value for stage, value in stage_s.items()},
            "code tokens in/out": (
                f"{sum(r.tokens.code_prompt for r in done)}/{sum(r.tokens.code_completion for r in done)}"
            ),
            "answer tokens in/out": (
                f"{sum(r.tokens.answer_prompt for r in done)}/{sum(r.tokens.answer_completion for r in done)}"
            ),
            "wall s": self.wall_s,
        }

    def error_kinds(self) -> Counter:
        return Counter(
            attempt.error_kind or "error"
            for response in self.responses
            if response is not None
            for attempt in response.attempts
            if attempt.error is not None
        )


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m bench.real_model", description=__doc__.split("\n")[0])
    parser.add_argument("--questions", type=int, default=24)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--max-repairs", type=int, default=None, help="Default: PYSPATIAL_MAX_REPAIRS.")
    parser.add_argument("--json-out", type=Path, default=None, help="Write every response here (JSONL).")
    parser.add_argument("--all-families", action="store_true", help="Not only text-clue questions.")
    parser.add_argument("--record", type=Path, default=None, help="Write the code model's replies here.")
    parser.add_argument(
        "--parquet",
        type=Path,
        default=None,
        help="Ask the questions of this MMSI-schema parquet instead (real photos, classical backbone; "
        "e.g. the held-out templeRing set of `python -m bench mmsi_templering --write-only`).",
    )
    return parser.parse_args(argv)


TEXT_CLUE_FAMILIES = ("self_movement",)


def prompt_hash() -> str:
    """A short hash of the code prompt and its examples, as the agent renders them now."""
    from services.agent.codegen import DEFAULT_TEMPLATE
    from services.agent.example_choice import EXAMPLES_NAME
    from services.agent.prompts import PROMPT_DIR, available_versions

    examples = f"{EXAMPLES_NAME}_v{max(available_versions(EXAMPLES_NAME))}.md"  # the latest, as served
    text = "".join(
        (PROMPT_DIR / name).read_text(encoding="utf-8")
        for name in (f"{DEFAULT_TEMPLATE}.md", examples, "repair_v2.md")
    )
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _questions(args: argparse.Namespace, data_dir: Path) -> list[BenchmarkItem]:
    """The first `--questions` items (text-clue ones unless --all-families) of enough scenes, or of
    the --parquet file."""
    if args.parquet is not None:
        from evaluation.mmsi import read_mmsi

        return list(read_mmsi(args.parquet, data_dir / "images", limit=args.questions))
    per_scene = QUESTIONS_PER_SCENE if args.all_families else 2  # two motion questions per scene
    scenes = math.ceil(args.questions / per_scene) + (0 if args.all_families else 1)
    jsonl = make_dataset(data_dir, num_scenes=scenes, seed=args.seed, width=args.width, height=args.height)
    items = read_mindcube(jsonl, data_dir)
    if not args.all_families:
        items = [
            item for item in items if item.intent is not None and item.intent.family in TEXT_CLUE_FAMILIES
        ]
    return items[: args.questions]


@contextlib.contextmanager
def _services(work_dir: Path, backbone: str) -> Iterator[tuple[str, str, str]]:
    """(recon URL, model agent URL, offline agent URL)."""
    env = {
        "PYSPATIAL_DATA_DIR": str(work_dir / "service-data"),
        "PYSPATIAL_CACHE_NAMESPACE": f"bench-real-model-{uuid.uuid4().hex}",
        "PYSPATIAL_BACKBONE": backbone,
    }
    with running_service("services.recon.app:create_app", env) as recon:
        agent_env = {**env, "PYSPATIAL_RECON_URL": recon.url}
        with (
            running_service("services.agent.app:create_app", agent_env) as model_agent,
            running_service("services.agent.app:create_app", {**agent_env, **OFFLINE_ENV}) as offline_agent,
        ):
            yield recon.url, model_agent.url, offline_agent.url


def _solve(
    agent: AgentClient, item: BenchmarkItem, scene_id: str | None, max_repairs: int | None, backbone: str
):
    try:
        if scene_id is None:
            return agent.solve(item.question, images=item.images, max_repairs=max_repairs), None
        return agent.solve(item.question, scene_id=scene_id, backbone=backbone, max_repairs=max_repairs), None
    except (ServiceError, ServiceUnreachable) as error:
        return None, str(error)


def _markdown(rows: list[dict[str, object]]) -> str:
    columns = list(rows[0])
    lines = ["| " + " | ".join(columns) + " |", "| --- |" + " ---: |" * (len(columns) - 1)]
    for row in rows:
        cells = [f"{value:.1f}" if isinstance(value, float) else str(value) for value in row.values()]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = _arguments(argv)
    settings = AgentSettings()
    if not settings.code_model:
        raise SystemExit(
            "set PYSPATIAL_CODE_MODEL and PYSPATIAL_CODE_MODEL_BASE_URL to the model to measure "
            "(see README: 'A real code model')"
        )
    with contextlib.ExitStack() as stack:
        work_dir = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="bench-real-model-")))
        items = _questions(args, work_dir / "dataset")
        data_dir = work_dir / "dataset"
        backbone = "classical" if args.parquet is not None else "posed-rgbd"
        recon_url, model_url, offline_url = stack.enter_context(_services(work_dir, backbone))
        recon = stack.enter_context(ReconClient(recon_url))
        uploader = ExactSceneUploader(recon, data_dir)
        model_agent = stack.enter_context(AgentClient(model_url, timeout=3600))
        offline_agent = stack.enter_context(AgentClient(offline_url, timeout=3600))
        model_run = SystemRun(f"{settings.code_model} (+ {settings.answer_model or 'offline answerer'})")
        offline_run = SystemRun("offline planner + offline answerer")
        families: list[str] = []
        records = []
        for item in items:
            truth = read_choice(item.gt_answer) or item.gt_answer
            # real photos go up once as a plain scene: both agents ask about it, reconstructed once
            scene_id = (
                uploader.scene_id(item) if args.parquet is None else recon.upload_scene(item.images).scene_id
            )
            families.append(item.type or "unknown")
            for run, agent in ((model_run, model_agent), (offline_run, offline_agent)):
                started = time.perf_counter()
                response, error = _solve(agent, item, scene_id, args.max_repairs, backbone)
                run.wall_s += time.perf_counter() - started
                run.add(response, error, truth)
                records.append(
                    {
                        "id": item.id,
                        "system": run.label,
                        "truth": truth,
                        "error": error,
                        "response": response.model_dump(mode="json") if response else None,
                    }
                )
    if args.json_out:
        args.json_out.write_text("".join(json.dumps(record) + "\n" for record in records), encoding="utf-8")
    if args.record:
        _record(args, settings, items, model_run)

    endpoint = settings.code_model_base_url or "https://api.openai.com/v1"
    text_only = " (text only)" if settings.code_model_text_only else ""
    source = (
        f"questions of {args.parquet.name} (classical backbone)"
        if args.parquet is not None
        else f"synthetic questions (seed {args.seed}, {args.width}x{args.height}, posed-rgbd)"
    )
    print(
        f"### Real code model: {settings.code_model}{text_only} at {endpoint}, {len(items)} {source}, "
        f"prompt {prompt_hash()}\n"
    )
    print(_markdown([model_run.row(), offline_run.row()]))
    print("\nFailed attempts by kind:")
    for run in (model_run, offline_run):
        kinds = ", ".join(f"{kind} {count}" for kind, count in run.error_kinds().most_common()) or "none"
        print(f"- {run.label}: {kinds}")
    print(
        "\n| family | questions | "
        + " | ".join(f"{r.label}: answered / correct" for r in (model_run, offline_run))
        + " |"
    )
    print("| --- | ---: |" + " ---: |" * 2)
    _family_rows(families, model_run, offline_run)
    print(f"\nPer question ({model_run.label}; prompt {prompt_hash()}):\n")
    print(
        _markdown(
            [
                _question_row(item, r, ok)
                for item, r, ok in zip(items, model_run.responses, model_run.correct, strict=True)
            ]
        )
    )
    return 0


def _family_rows(families: list[str], model_run: SystemRun, offline_run: SystemRun) -> None:
    for family in sorted(set(families)):
        index = [i for i, name in enumerate(families) if name == family]
        cells = [
            f"{sum(run.answered[i] for i in index)} / {sum(run.correct[i] for i in index)}"
            for run in (model_run, offline_run)
        ]
        print(f"| {family} | {len(index)} | " + " | ".join(cells) + " |")


def _question_row(item: BenchmarkItem, response: SolveResponse | None, correct: bool) -> dict[str, object]:
    model_attempts = [a for a in response.attempts if a.reply is not None] if response else []
    kinds = [a.error_kind or "error" for a in (response.attempts if response else []) if a.error]
    return {
        "question": item.id,
        "asks": " -> ".join(map(str, item.intent.motion_pair or ())) if item.intent else "",
        "program source": (response.program_source if response else None) or "none",
        "model attempts": len(model_attempts),
        "failed kinds": ", ".join(kinds) or "-",
        "answer": (response.answer if response else None) or "-",
        "truth": read_choice(item.gt_answer) or item.gt_answer,
        "right": "yes" if correct else "no",
    }


def _record(
    args: argparse.Namespace, settings: AgentSettings, items: list[BenchmarkItem], run: SystemRun
) -> None:
    """The run's facts for a replay: seed, sizes, model, prompt hash, and per question its outcome."""
    facts = {
        "seed": args.seed,
        "questions": len(items),
        "width": args.width,
        "height": args.height,
        "max_repairs": args.max_repairs,
        "model": settings.code_model,
        "prompt": prompt_hash(),
        "results": [
            {
                "id": item.id,
                "program_source": r.program_source if r else None,
                "answer": r.answer if r else None,
                "model_replies": [a.reply for a in r.attempts if a.reply is not None] if r else [],
            }
            for item, r in zip(items, run.responses, strict=True)
        ],
    }
    args.record.write_text(json.dumps(facts, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    raise SystemExit(main())
