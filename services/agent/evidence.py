"""Evidence, not assertions: which lines of a program's text output the program typed in itself.

A code model that cannot see the scene often "answers" inside its program: it returns an option's
text ("farther from the bookshelf") chosen by comparing invented coordinates, or fills a template
("Turned {side} by about {x:.2f} units.") with its own words. Such output carries no information
from the tools, and treating it as a clue turns a guess into a confident wrong answer. A line of
output counts as typed in when

- it contains the text of an option that also appears inside one of the program's string literals, or
- it is made only of the program's string literals and punctuation, or
- it is made only of the program's literals, numbers and punctuation and states a motion or a turn
  ("Turned {side} by about {x:.2f} units."): the claim's words came from the program, whatever
  numbers fill it. A line of literals and numbers that claims no motion ("heading change: 35
  degrees") passes: the number may well be computed from the tools.

Tool output (camera-motion sentences, image handles) is never made of the program's literals, so it
passes. A program that computes a side from real geometry and prints it with its own words is
caught too: that costs a repair round, where a typed-in claim accepted as evidence would cost a
confidently wrong answer. Only programs written by a model are checked; the offline planner's
programs compute their sentences from the geometry with the same rules as the recon service.
"""

from __future__ import annotations

import ast
import re

from services.agent.program_cleanup import UNPARSABLE_ERRORS
from shared.questions.choices import normalize_direction, normalize_turn
from shared.questions.intent import QuestionIntent

_MIN_LITERAL_CHARS = 2
_ONLY_NUMBERS_AND_PUNCTUATION = re.compile(r"^[\W\d_]*$")


def _normalized(text: str) -> str:
    return " ".join(text.lower().split())


def program_literals(program: str) -> list[str]:
    """The string constants of a program (f-string pieces included), normalized, longest first."""
    try:
        tree = ast.parse(program)
    except UNPARSABLE_ERRORS:
        return []
    found = {
        _normalized(node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str)
    }
    return sorted((text for text in found if len(text) >= _MIN_LITERAL_CHARS), key=len, reverse=True)


def _contains(text: str, part: str) -> bool:
    """`part` occurs in `text` as whole words."""
    return re.search(rf"(?<!\w){re.escape(part)}(?!\w)", text) is not None


def _typed_options(literals: list[str], options: dict[str, str]) -> dict[str, str]:
    return {
        letter: _normalized(text)
        for letter, text in options.items()
        if text.strip() and any(_contains(literal, _normalized(text)) for literal in literals)
    }


def _made_of_literals(line: str, literals: list[str]) -> bool:
    rest = line
    for literal in literals:
        rest = rest.replace(literal, " ")
    if rest == line or not _ONLY_NUMBERS_AND_PUNCTUATION.match(rest):
        return False
    if not any(character.isdigit() for character in rest):
        return True  # nothing but the program's own words
    return normalize_direction(line) is not None or normalize_turn(line) is not None


def typed_in_lines(
    clue_text: str | None, program: str, intent: QuestionIntent
) -> tuple[str | None, list[str]]:
    """(the clue text without typed-in lines, one note per line left out); options from the intent."""
    if not clue_text or not clue_text.strip():
        return clue_text, []
    literals = program_literals(program)
    if not literals:
        return clue_text, []
    typed = _typed_options(literals, intent.options)
    kept, notes = [], []
    for line in clue_text.splitlines():
        normalized = _normalized(line)
        named = sorted(letter for letter, text in typed.items() if _contains(normalized, text))
        if named or (normalized and _made_of_literals(normalized, literals)):
            what = f"option {', '.join(named)}'s text" if named else "its own words"
            notes.append(
                f"Ignored the output {line.strip()[:120]!r}: the program typed {what} itself, "
                "so it is not evidence from the tools."
            )
        else:
            kept.append(line)
    text = "\n".join(kept).strip()
    return (text or None), notes


__all__ = ["program_literals", "typed_in_lines"]
