"""Which in-context examples the code prompt shows: the ones most like the question, first.

Each example's question is parsed with the same parser as the user's (shared.questions.intent), so
an example's family (self-movement, relative direction, what-if) and program kind (motion, left,
turn_and_move, ...) are read, not hand-labelled. Examples of the question's program kind come first,
then those of its family, then the rest in file order; the prompt shows the first `count`.
"""

from __future__ import annotations

from functools import lru_cache

from services.agent.planner import PlanningError, UnplannableQuestion, plan_intent
from services.agent.prompts import PromptExample, load_examples
from shared.questions.intent import QuestionIntent, parse_question

EXAMPLES_NAME = "codegen_examples"  # the latest codegen_examples_v<N>.md
MAX_VIEWS = 10


def program_kind(intent: QuestionIntent) -> str | None:
    """The kind of program the offline planner writes for the intent (None: it writes none)."""
    try:
        return plan_intent(intent, MAX_VIEWS).family
    except (PlanningError, UnplannableQuestion):
        return None


@lru_cache(maxsize=8)
def _example_intents(name: str) -> tuple[tuple[PromptExample, QuestionIntent, str | None], ...]:
    examples = []
    for example in load_examples(name):
        intent = parse_question(example.question, MAX_VIEWS)
        examples.append((example, intent, program_kind(intent)))
    return tuple(examples)


def choose_examples(
    count: int, intent: QuestionIntent | None = None, name: str = EXAMPLES_NAME
) -> list[PromptExample]:
    """The `count` examples to show; in file order when the question's intent is unknown."""
    described = _example_intents(name)
    if intent is None:
        return [example for example, _, _ in described[:count]]
    kind = program_kind(intent)

    def rank(entry: tuple[int, tuple[PromptExample, QuestionIntent, str | None]]) -> tuple[int, int]:
        position, (_, example_intent, example_kind) = entry
        if kind is not None and example_kind == kind:
            return 0, position
        if example_intent.family == intent.family:
            return 1, position
        return 2, position

    ordered = sorted(enumerate(described), key=rank)
    return [example for _, (example, _, _) in ordered[:count]]


__all__ = ["EXAMPLES_NAME", "choose_examples", "program_kind"]
