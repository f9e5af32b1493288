"""read_choice: the one answer extractor (agent, evaluation, benches) on a table of model replies."""

from __future__ import annotations

import pytest

from evaluation.answers import answer_letter
from services.agent.answering import read_model_answer
from shared.questions.choices import read_choice
from shared.questions.intent import parse_question

OPTIONS = {"A": "Left", "B": "Right", "C": "Front-left", "D": "Behind"}
QUESTION = "From image 2, where is the lamp? A. Left B. Right C. Front-left D. Behind"

# Replies in the shapes Qwen2.5-Coder-1.5B and similar small models give, with the letter a reader
# would take from each (None: the reply commits to nothing, so no letter is guessed).
TABLE = [
    ("B", "B"),
    ("Answer: b) left", "B"),
    ("I would say it's B, not A.", "B"),
    ("It is not A.", None),
    ("<answer>C</answer>", "C"),
    ("<think>A looks close, but</think><answer>D</answer>", "D"),
    ("The answer is not A. The answer is C.", "C"),
    ('{"reasoning": "The clue says the camera moved right.", "answer": "B"}', "B"),
    ('{"reasoning": "The clue says right.", "answer": "Right"}', "B"),
    ("The lamp is to the front-left of the camera.", "C"),
    ("Not left: the lamp is on the right.", "B"),
    ("From view 2 the lamp is behind me.", "D"),
    ("The clue says the camera moved right.\nA is wrong because it says left.\nB", "B"),
    ("**Answer:** (D)", "D"),
    ("Either B or C.", None),
    ("I cannot tell from the clue.", None),
    ("The answer is E.", None),
    ("", None),
]


@pytest.mark.parametrize(("reply", "letter"), TABLE)
def test_read_choice_table(reply: str, letter: str | None) -> None:
    assert read_choice(reply, OPTIONS) == letter


@pytest.mark.parametrize(("reply", "letter"), TABLE)
def test_the_agent_and_the_evaluation_read_the_same_letter(reply: str, letter: str | None) -> None:
    intent = parse_question(QUESTION)
    assert intent.options == OPTIONS
    assert answer_letter(reply, intent) == letter
    assert read_model_answer(reply, OPTIONS).answer == letter


def test_letters_only_still_read_letters() -> None:
    assert read_choice("Answer: c", "ABCD") == "C"
    assert read_choice("the front-left one", "ABCD") is None  # no texts: no option to name
