"""Read multiple-choice questions and answers: option letters, answer letters, direction wording.

MindCube questions inline their options ("... A. Left B. Right C. Behind") or put one per line,
sometimes as "(A) Left". Models answer "C", "(C) the sofa", "Answer: C" or "**C**". Directions
come in many spellings ("front left", "forward-left", "diagonally forward and left"); this module
maps them onto the eight canonical names that shared/geometry/camera_motion.py prints, and keeps turns
("turned left") apart from movements ("moved left") because they answer different questions.
"""

from __future__ import annotations

import json
import re
import string
from collections.abc import Iterable, Mapping

from shared.geometry.camera_motion import DIRECTIONS

TURNS = ("turn left", "turn right", "turn around", "no turn")

# An option marker: "A." / "A)" / "A:" or "(A)", not glued to a preceding word, followed by space.
_OPTION_MARKER = re.compile(r"(?<![A-Za-z0-9])(?:\(([A-Z])\)|([A-Z])[.):])(?=\s)")


def parse_options(question: str) -> dict[str, str]:
    """Options of a multiple-choice question, e.g. {"A": "Left", "B": "Right"}; {} when none.

    Options must run A, B, C, ... in order. Of several such runs the longest wins, the later one on a
    tie (options close a question). An option's text ends at the next marker or at the line end.
    """
    markers = [
        (match.group(1) or match.group(2), match.start(), match.end())
        for match in _OPTION_MARKER.finditer(question)
    ]
    best: list[tuple[str, int, int]] = []
    for start_index, (letter, _, _) in enumerate(markers):
        if letter != "A":
            continue
        run = [markers[start_index]]
        for candidate in markers[start_index + 1 :]:
            if candidate[0] == chr(ord(run[-1][0]) + 1):
                run.append(candidate)
        if len(run) >= 2 and len(run) >= len(best):
            best = run
    options: dict[str, str] = {}
    for position, (letter, _, text_start) in enumerate(best):
        text_end = best[position + 1][1] if position + 1 < len(best) else len(question)
        text = question[text_start:text_end].split("\n", 1)[0]
        options[letter] = text.strip().rstrip(",;").strip()
    return options


def split_options(question: str) -> tuple[str, dict[str, str]]:
    """(the stem before the options, the options); the whole text and {} when there are none."""
    options = parse_options(question)
    if not options:
        return question.strip(), {}
    markers = [m for m in _OPTION_MARKER.finditer(question) if (m.group(1) or m.group(2)) == "A"]
    # The options' run starts at the "A" marker whose text is option A's.
    for marker in reversed(markers):
        rest = question[marker.end() :].split("\n", 1)[0].strip()
        if rest.startswith(options["A"]):
            return question[: marker.start()].strip(), options
    return question.strip(), options


_MARKDOWN = re.compile(r"[*_`#]")
_TAGGED = re.compile(r"<(answer|ans)>(.*?)(?:</\1\s*>|$)", re.IGNORECASE | re.DOTALL)
_THINKING = re.compile(r"<(think|thinking|reasoning)>.*?(?:</\1\s*>|$)", re.IGNORECASE | re.DOTALL)
_ALONE = re.compile(r"^\s*[\(\[]?([A-Za-z])[\)\]]?\s*[.:)]?\s*$")
_KEYWORDS = (
    r"(?:final\s+answer|correct\s+(?:answer|option|choice)|answer|option|choice|final|selected|selection"
    r"|i\s+(?:choose|chose|pick|picked|select|selected|go\s+with))"
)
_KEYED_UPPER = re.compile(
    rf"(?i:{_KEYWORDS})(?i:\s+(?:is|would\s+be|should\s+be|will\s+be))?\s*[:=\-]?\s*(?i:option\s+)?"
    r"[\(\[]?((?-i:[A-Z]))(?![A-Za-z0-9'])"
)
# A lower-case letter after a keyword only when punctuation marks it as a letter ("Answer: b)", "(c)"),
# so that "the answer is a door" is not option A.
_KEYED_LOWER = re.compile(
    rf"(?i:{_KEYWORDS})(?i:\s+(?:is|would\s+be|should\s+be|will\s+be))?\s*[:=\-]?\s*(?i:option\s+)?"
    r"(?:\(([a-z])\)|\[([a-z])\]|([a-z])(?:[).:,;](?=\s|$)|\s*$))"
)
_LEADING = re.compile(r"^\s*[\(\[]?([A-Z])(?:[\)\]]|[.:)](?=\s|$))")
_LEADING_LOWER = re.compile(r"^\s*(?:\(([a-z])\)|([a-z])[.)](?=\s|$))")
_STANDALONE = re.compile(r"(?<![A-Za-z0-9'])([A-Z])(?![A-Za-z0-9'])")


def _json_answer(text: str) -> str | None:
    """The "answer" value of the first JSON object in the text that has one."""
    decoder = json.JSONDecoder()
    for match in re.finditer(r"\{", text):
        try:
            value, _ = decoder.raw_decode(text, match.start())
        except json.JSONDecodeError:
            continue
        if isinstance(value, dict):
            for key, stated in value.items():
                if str(key).lower() in ("answer", "final_answer", "choice", "option") and stated is not None:
                    return str(stated)
    return None


# "not A", "isn't A", "rather than A", "instead of A": a letter the reply rules out.
_NEGATED = re.compile(
    r"(?i:\bnot|\bisn't|\bisn’t|\bnor|\brather\s+than|\binstead\s+of|\bexcept|\bexcluding)"
    r"\s+(?i:option\s+|choice\s+)?[\(\[]?$"
)


def _negated(plain: str, position: int) -> bool:
    return bool(_NEGATED.search(plain[max(0, position - 24) : position]))


def _keyed_letter(plain: str, allowed: set[str]) -> str | None:
    keyed = [(m.start(1), m.group(1)) for m in _KEYED_UPPER.finditer(plain)]
    for match in _KEYED_LOWER.finditer(plain):
        group = next(index for index in (1, 2, 3) if match.group(index))
        keyed.append((match.start(group), match.group(group).upper()))
    keyed = [(position, letter) for position, letter in keyed if letter in allowed]
    return max(keyed)[1] if keyed else None  # "... not A ... the answer is C": the conclusion comes last


def _letter_in(text: str, allowed: set[str]) -> str | None:
    plain = _MARKDOWN.sub("", text).strip()
    if not plain:
        return None
    alone = _ALONE.match(plain)
    if alone and alone.group(1).upper() in allowed:
        return alone.group(1).upper()
    keyed = _keyed_letter(plain, allowed)
    if keyed:
        return keyed
    last_line = _ALONE.match(plain.splitlines()[-1])  # a reasoning paragraph, then the letter alone
    if last_line and last_line.group(1).upper() in allowed:
        return last_line.group(1).upper()
    for pattern in (_LEADING, _LEADING_LOWER):
        leading = pattern.match(plain)
        if leading:
            letter = next(g for g in leading.groups() if g).upper()
            if letter in allowed:
                return letter
    found = set()
    for match in _STANDALONE.finditer(plain):
        letter = match.group(1)
        # "A chair", "I think": the article and the pronoun are words, not options.
        if letter in "AI" and re.match(r"\s+(?!(?:or|and|nor|vs)\b)[a-z]", plain[match.end() :]):
            continue
        if letter in allowed and not _negated(plain, match.start()):
            found.add(letter)
    return found.pop() if len(found) == 1 else None


def _option_named(text: str, options: Mapping[str, str]) -> str | None:
    """The letter of the only option whose text the reply names (whole words, not ruled out)."""
    lowered = _MARKDOWN.sub("", text).lower()
    named = set()
    for letter, option in options.items():
        if not option.strip():
            continue
        for match in re.finditer(rf"(?<!\w){re.escape(option.strip().lower())}(?!\w)", lowered):
            if not _negated(lowered, match.start()):
                named.add(letter)
    # "front-left" contains "left": keep only options not inside another named option's text.
    named = {
        letter
        for letter in named
        if not any(other != letter and options[letter].lower() in options[other].lower() for other in named)
    }
    return named.pop() if len(named) == 1 else None


def read_choice(text: str | None, options: Mapping[str, str] | Iterable[str] | None = None) -> str | None:
    """The option a reply commits to, or None when it commits to none (or to several): never a guess.

    The one answer extractor: the agent, the evaluation and every bench read replies with it.
    `options` is the question's options ({"A": "Left", ...}) or just the allowed letters; without
    them any capital letter counts. In order: the last ``<answer>...</answer>`` (or ``<ans>``) tag,
    MindCube's own format; a JSON object's "answer"; then the text with ``<think>...</think>``
    removed: a letter alone ("C", "b)"), the last keyed letter ("Answer: b) left", "The answer is
    (B)."), a letter alone on the last line, a leading letter ("C. the sofa"), the only standalone
    capital that is not ruled out ("B, not A" is B; "not A" alone is nothing); and, when no letter is
    named, the only option whose text the reply names.
    """
    texts = dict(options) if isinstance(options, Mapping) else {}
    allowed = set(texts or (options or string.ascii_uppercase))
    text = text or ""
    candidates = [body for _, body in _TAGGED.findall(text)][-1:]
    text = _THINKING.sub(" ", text)
    stated = _json_answer(text)
    candidates += [stated] if stated is not None else []
    for candidate in candidates:
        letter = _letter_in(candidate, allowed) or (_option_named(candidate, texts) if texts else None)
        if letter:
            return letter
    letter = _letter_in(text, allowed)
    if letter is None and texts:
        letter = _option_named(text, texts)
    return letter


def extract_letter(text: str, valid_letters: Iterable[str] | None = None) -> str | None:
    """`read_choice` with only the allowed letters (kept for callers that have no option texts)."""
    return read_choice(text, valid_letters)


def _words(text: str) -> str:
    """Lower case, hyphens and punctuation to spaces, single spaces."""
    lowered = re.sub(r"[-_/]", " ", (text or "").lower())
    lowered = re.sub(r"[^a-z0-9°.\s]", " ", lowered)
    return " ".join(lowered.split())


# Words allowed between a turn verb and its side: "turned 90 degrees to the left", "rotated by about 45°".
_TURN_FILLER = (
    r"(?:(?:by|to|the|your|my|its|about|around|roughly|approximately|slightly|sharply"
    r"|\d+(?:\.\d+)?°?|°|degrees?|deg)\s+)*"
)
_TURN = re.compile(
    r"\b(?:turn|turned|turning|turns|rotate|rotated|rotating|rotates|rotation|pan|panned|panning|yaw|yawed)\s+"
    + _TURN_FILLER
    + r"(left|right|around|round|back)\b"
)
_TURN_AROUND = re.compile(r"\b(?:about face|u turn|180 degrees?|180 ?°|face the opposite direction)\b")
_NO_TURN = re.compile(
    r"\b(?:no (?:significant )?(?:rotation|turn|turning)|without (?:turning|rotating)|did not (?:turn|rotate)"
    r"|didn t (?:turn|rotate)|not (?:turn|rotate)|nor turned)"
)

_FORWARD = re.compile(r"\b(?:forwards?|forth|ahead|front|frontward|frontwards|straight)\b")
_BACKWARD = re.compile(r"\b(?:back|backs|backward|backwards|behind|rear|rearward|rearwards|reverse)\b")
_LEFT = re.compile(r"\b(?:left|leftward|leftwards)\b")
_RIGHT = re.compile(r"\b(?:right|rightward|rightwards)\b")
_NO_MOVE = re.compile(
    r"\b(?:no (?:significant )?movement|neither moved|stayed in place|did not move|didn t move|stood still)\b"
)


def _without_turns(words: str) -> str:
    words = _TURN.sub(" ", words)
    words = _TURN_AROUND.sub(" ", words)
    return _NO_TURN.sub(" ", words)


def normalize_direction(text: str) -> str | None:
    """The canonical movement direction a phrase names (one of DIRECTIONS), or None.

    Turning is not moving: "turned left" gives None, "turn left and walk forward" gives "forward".
    Contradictions ("back and forth", "left or right") give None.
    """
    words = _without_turns(_words(text))
    if _NO_MOVE.search(words):
        return None
    forward = bool(_FORWARD.search(words))
    backward = bool(_BACKWARD.search(words))
    left = bool(_LEFT.search(words))
    right = bool(_RIGHT.search(words))
    if (forward and backward) or (left and right):
        return None
    side = "left" if left else "right" if right else None
    depth = "forward" if forward else "back" if backward else None
    if depth and side:
        return f"diagonally {depth} and {side}"
    if depth:
        return "forward" if depth == "forward" else "backward"
    return side


def normalize_turn(text: str) -> str | None:
    """The turn a phrase names: "turn left", "turn right", "turn around", "no turn", or None.

    "Turned left by about 45 degrees", "rotated 90° to the right", "did a U-turn", "without turning".
    Several different turns in one phrase give None.
    """
    words = _words(text)
    found = set()
    for match in _TURN.finditer(words):
        side = match.group(1)
        found.add("turn around" if side in ("around", "round", "back") else f"turn {side}")
    if _TURN_AROUND.search(words):
        found.add("turn around")
    if not found and _NO_TURN.search(words):
        found.add("no turn")
    return found.pop() if len(found) == 1 else None


_DEGREES = re.compile(r"(\d+(?:\.\d+)?)\s*(?:°|degrees?\b|deg\b)")


def turn_degrees(text: str) -> float | None:
    """How many degrees a turn phrase states ("turned left by about 45 degrees" gives 45.0).

    A turn around with no number is 180; no turn is 0; a phrase with no turn gives None.
    """
    turn = normalize_turn(text)
    if turn is None:
        return None
    if turn == "no turn":
        return 0.0
    stated = _DEGREES.search(_words(text))
    if stated:
        return float(stated.group(1))
    return 180.0 if turn == "turn around" else None


__all__ = [
    "DIRECTIONS",
    "TURNS",
    "extract_letter",
    "split_options",
    "normalize_direction",
    "normalize_turn",
    "parse_options",
    "read_choice",
    "turn_degrees",
]
