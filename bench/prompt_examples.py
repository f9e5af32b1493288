"""How many in-context examples the code prompt needs: coverage of the questions against prompt size.

    python -m bench.prompt_examples --scenes 24 --seed 0

No language model is needed (none can be run here): for each synthetic MindCube-style question
(shared/synthetic, worded like the benchmark) and each example count, the code prompt is built as
the agent builds it, and the bench records whether the examples shown include one of the
question's own program kind (the program the offline planner writes for it: motion, left, behind,
turn_and_move, ...) and one of its own family (self-movement, relative direction, what-if), and how
long the prompt is. It does so for the examples in file order and in the agent's order (most like
the question first, services/agent/example_choice.py). The default count is the smallest that
reaches the best coverage in the agent's order; a real-model bench can refine it.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from collections.abc import Iterable
from pathlib import Path

from rich.console import Console
from rich.table import Table

from services.agent.codegen import MAX_EXAMPLES, build_codegen_messages
from services.agent.example_choice import choose_examples, program_kind
from shared.questions.intent import QuestionIntent, parse_question
from shared.synthetic import make_dataset

TOKENS_PER_CHAR = 0.25  # a rough English/code average; the figures say "about"


def _questions(scenes: int, seed: int) -> list[tuple[str, int]]:
    with tempfile.TemporaryDirectory(prefix="bench-examples-") as folder:
        jsonl = make_dataset(folder, num_scenes=scenes, seed=seed, width=32, height=24)
        records = [json.loads(line) for line in Path(jsonl).read_text().splitlines()]
    return [(record["question"], len(record["images"])) for record in records]


def _coverage(
    intents: Iterable[tuple[QuestionIntent, str | None]], count: int, ordered: bool
) -> tuple[float, float]:
    kind_hits = family_hits = total = 0
    for intent, kind in intents:
        shown = choose_examples(count, intent if ordered else None)
        shown_intents = [parse_question(example.question, 10) for example in shown]
        total += 1
        kind_hits += any(program_kind(shown_intent) == kind for shown_intent in shown_intents)
        family_hits += any(shown_intent.family == intent.family for shown_intent in shown_intents)
    return kind_hits / total, family_hits / total


def _prompt_chars(questions: list[tuple[str, int]], count: int) -> float:
    sizes = []
    for question, _ in questions:
        messages = build_codegen_messages(
            parse_question(question), [], num_examples=count, rank_examples=False
        )
        sizes.append(sum(len(part["text"]) for part in messages[0]["content"] if part["type"] == "text"))
    return sum(sizes) / len(sizes)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.prompt_examples", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--scenes", type=int, default=24)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    questions = _questions(args.scenes, args.seed)
    intents = [(intent, program_kind(intent)) for intent in (parse_question(q, n) for q, n in questions)]
    console = Console(width=140)
    table = Table(title=f"Code-prompt examples: coverage of {len(questions)} synthetic questions (%)")
    for name in ("Examples", "Kind (file order)", "Family (file order)", "Kind (agent order)",
                 "Family (agent order)", "Prompt chars", "~tokens"):  # fmt: skip
        table.add_column(name, justify="right")
    best: tuple[float, float] | None = None
    chosen = 0
    for count in range(MAX_EXAMPLES + 1):
        fixed = _coverage(intents, count, ordered=False)
        ordered = _coverage(intents, count, ordered=True)
        chars = _prompt_chars(questions, count)
        if best is None or ordered > best:
            best, chosen = ordered, count
        table.add_row(
            str(count),
            *(f"{100 * value:.1f}" for value in (*fixed, *ordered)),
            f"{chars:.0f}",
            f"{chars * TOKENS_PER_CHAR:.0f}",
        )
    console.print(table)
    console.print(f"smallest count with the best coverage in the agent's order: {chosen}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
