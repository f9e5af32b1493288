"""shared.questions.choices: options, answer letters, direction and turn wording."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from shared.questions.choices import (
    DIRECTIONS,
    extract_letter,
    normalize_direction,
    normalize_turn,
    parse_options,
    turn_degrees,
)
from shared.questions.intent import parse_question

MINDCUBE_INLINE = (
    "Based on these two views showing the same scene: in which direction did I move from the first view "
    "to the second view? A. Diagonally forward and right B. Diagonally forward and left C. Forward "
    "D. Backward"
)


def test_inline_options() -> None:
    assert parse_options(MINDCUBE_INLINE) == {
        "A": "Diagonally forward and right",
        "B": "Diagonally forward and left",
        "C": "Forward",
        "D": "Backward",
    }


def test_options_one_per_line_with_parentheses_and_trailing_instruction() -> None:
    question = "From image 3, what is behind me?\n(A) a sofa\n(B) a TV set\n(C) the window\nAnswer: a letter."
    assert parse_options(question) == {"A": "a sofa", "B": "a TV set", "C": "the window"}


def test_options_with_colons_and_parentheses_markers() -> None:
    assert parse_options("Which side? A) left B) right") == {"A": "left", "B": "right"}
    assert parse_options("Options: A: left, B: right") == {"A": "left", "B": "right"}


def test_a_stray_letter_before_the_options_is_not_an_option() -> None:
    question = "Plan A. Then, where is the lamp? A. Left of me B. Right of me C. Behind me"
    assert parse_options(question) == {"A": "Left of me", "B": "Right of me", "C": "Behind me"}


def test_no_options() -> None:
    assert parse_options("What is behind me?") == {}
    assert parse_options("Only A. one option") == {}


@pytest.mark.parametrize(
    ("reply", "letter"),
    [
        ("C", "C"),
        ("C.", "C"),
        (" (C) ", "C"),
        ("(C) the sofa", "C"),
        ("C. the sofa", "C"),
        ("Answer: C", "C"),
        ("answer: (B)", "B"),
        ("**C**", "C"),
        ("The answer is **D**.", "D"),
        ("The correct option is B because the lamp is left.", "B"),
        ("It is not A. The answer is C.", "C"),
        ("I think B", "B"),
        ("A chair is visible, so B", "B"),
    ],
)
def test_extract_letter(reply: str, letter: str) -> None:
    assert extract_letter(reply, "ABCD") == letter


@pytest.mark.parametrize("reply", ["", "   ", "I am not sure", "Either B or C", "The answer is E"])
def test_extract_letter_gives_none_when_unclear(reply: str) -> None:
    assert extract_letter(reply, "ABCD") is None


def test_extract_letter_without_valid_letters_accepts_any_capital() -> None:
    assert extract_letter("Answer: F") == "F"


@pytest.mark.parametrize(
    ("phrase", "direction"),
    [
        ("forward", "forward"),
        ("Forwards", "forward"),
        ("straight ahead", "forward"),
        ("moved to the front", "forward"),
        ("back", "backward"),
        ("backwards", "backward"),
        ("Backward", "backward"),
        ("left", "left"),
        ("to the left", "left"),
        ("leftward", "left"),
        ("right", "right"),
        ("moved to the right", "right"),
        ("forward-left", "diagonally forward and left"),
        ("front left", "diagonally forward and left"),
        ("diagonally forward-left", "diagonally forward and left"),
        ("Diagonally forward and left", "diagonally forward and left"),
        ("forward and to the right", "diagonally forward and right"),
        ("front-right", "diagonally forward and right"),
        ("back right", "diagonally back and right"),
        ("diagonally backward and right", "diagonally back and right"),
        ("rear left", "diagonally back and left"),
        ("Diagonally back and left", "diagonally back and left"),
    ],
)
def test_normalize_direction(phrase: str, direction: str) -> None:
    assert normalize_direction(phrase) == direction


def test_every_canonical_direction_is_a_fixed_point() -> None:
    for direction in DIRECTIONS:
        assert normalize_direction(direction) == direction
        assert normalize_direction(direction.upper()) == direction


@pytest.mark.parametrize("phrase", ["back and forth", "left or right", "the sofa", "", "up"])
def test_normalize_direction_gives_none_for_no_or_contradictory_direction(phrase: str) -> None:
    assert normalize_direction(phrase) is None


def test_turns_are_not_movements() -> None:
    assert normalize_direction("turned left") is None
    assert normalize_direction("rotated right by 90 degrees") is None
    assert normalize_direction("turn left and walk forward") == "forward"
    assert normalize_turn("turn left and walk forward") == "turn left"
    assert normalize_turn("moved left") is None


@pytest.mark.parametrize(
    ("phrase", "turn"),
    [
        ("turned left", "turn left"),
        ("rotated right", "turn right"),
        ("turned left by about 45 degrees", "turn left"),
        ("rotated 90° to the right", "turn right"),
        ("turned 30 degrees to the left", "turn left"),
        ("panned right", "turn right"),
        ("turned around by about 180 degrees", "turn around"),
        ("did a U-turn", "turn around"),
        ("did not turn", "no turn"),
        ("without turning significantly", "no turn"),
        ("no significant rotation", "no turn"),
        ("neither moved nor turned significantly", "no turn"),
    ],
)
def test_normalize_turn(phrase: str, turn: str) -> None:
    assert normalize_turn(phrase) == turn


def test_camera_motion_sentence_has_both_notions() -> None:
    sentence = (
        "From view 1 to view 2 the camera moved diagonally forward and right "
        "and turned left by about 45 degrees."
    )
    assert normalize_direction(sentence) == "diagonally forward and right"
    assert normalize_turn(sentence) == "turn left"
    assert turn_degrees(sentence) == 45.0


def test_turn_degrees() -> None:
    assert turn_degrees("rotated 90° to the right") == 90.0
    assert turn_degrees("turned around") == 180.0
    assert turn_degrees("did not turn") == 0.0
    assert turn_degrees("turned left") is None
    assert turn_degrees("moved 3 degrees left") is None


# ---- options are parsed once, by the question parser ------------------------------------------------

REPO_ROOT = Path(__file__).resolve().parents[1]
THIS_FILE = "tests/test_choices.py"  # the parser's own tests call it
PARSER = {"shared/questions/choices.py", "shared/questions/intent.py"}  # the question parser
SOURCE_ROOTS = ("services", "shared", "evaluation", "cli", "bench", "tests")


def callers_of_parse_options(files: dict[str, str]) -> list[str]:
    """`path:line` of every call of `parse_options` in `files` (path -> Python source)."""
    found = []
    for path, source in files.items():
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Call):
                name = getattr(node.func, "id", None) or getattr(node.func, "attr", None)
                if name == "parse_options":
                    found.append(f"{path}:{node.lineno}")
    return found


def test_options_are_parsed_only_by_the_question_parser():
    """Everything below the parser reads `QuestionIntent.options` instead of re-reading the text."""
    files = {
        str(path.relative_to(REPO_ROOT)): path.read_text()
        for root in SOURCE_ROOTS
        for path in (REPO_ROOT / root).rglob("*.py")
    }
    assert any(
        caller.startswith("shared/questions/choices.py:") for caller in callers_of_parse_options(files)
    )
    outside = [c for c in callers_of_parse_options(files) if c.split(":")[0] not in PARSER | {THIS_FILE}]
    assert outside == []
    # The check finds a call that sneaks in, under either spelling.
    sneaked = {"services/agent/x.py": "from shared.questions import choices\nchoices.parse_options(q)\n"}
    assert callers_of_parse_options(sneaked) == ["services/agent/x.py:2"]


def test_the_intent_carries_the_options_as_asked_and_the_text_for_the_prompts():
    question = "From image 2, what is behind me?\nA. A door\nB. A window\nAnswer with the letter only."
    intent = parse_question(question, 2)
    # An option ends at its line's end, as parse_options reads the text as asked.
    assert intent.options == parse_options(question) == {"A": "A door", "B": "A window"}
    assert intent.family == "relative_direction" and intent.asked_view == 2 and intent.direction == "behind"
    assert intent.text == question and "text" not in intent.model_dump()  # for prompts, not sent back
