"""Turn free-form answers into comparable values: option letters, numbers, yes/no, short words."""

from __future__ import annotations

import re

from shared.questions.choices import read_choice
from shared.questions.intent import QuestionIntent

_NUMBER_WORDS = {
    word: value
    for value, word in enumerate(
        "zero one two three four five six seven eight nine ten eleven twelve thirteen fourteen "
        "fifteen sixteen seventeen eighteen nineteen twenty".split()
    )
}
_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d{1,3}(?:,\d{3})+|\d+)?(?:\.\d+)?(?:[eE][-+]?\d+)?(?!\d|\.\d)")
_TAGGED = re.compile(r"<ans>(.*?)</ans>", re.IGNORECASE | re.DOTALL)
_YES = {"yes", "true", "correct"}
_NO = {"no", "false", "incorrect"}


def answer_letter(text: str | None, intent: QuestionIntent | None = None) -> str | None:
    """The option letter in "C", "C.", "(C) the sofa", "Answer: C"; None when there is none.

    When the question (its parsed intent) lists options, only their letters count (so "I think" is
    not option I).
    """
    if not text:
        return None
    options = intent.options if intent is not None else {}
    return read_choice(text, options or None)


def tagged_answer(text: str) -> str:
    """The part inside <ans>...</ans> when a model used the tags (the last pair), else the text."""
    found = _TAGGED.findall(text or "")
    return found[-1].strip() if found else (text or "").strip()


def parse_number(text: str | None) -> float | None:
    """The number an answer gives: the last numeric token ("about 2.5 m" -> 2.5), or a number word.

    The last one wins because explanations come first and conclusions last ("1 chair and 2 tables,
    so 3"). Thousands separators are understood; units are ignored.
    """
    if not text:
        return None
    answer = tagged_answer(text)
    matches = [m.group(0) for m in _NUMBER.finditer(answer) if re.search(r"\d", m.group(0))]
    if matches:
        try:
            return float(matches[-1].replace(",", ""))
        except ValueError:
            return None
    words = re.findall(r"[a-z]+", answer.lower())
    spelled = [_NUMBER_WORDS[w] for w in words if w in _NUMBER_WORDS]
    return float(spelled[-1]) if spelled else None


def parse_yes_no(text: str | None) -> str | None:
    """ "yes" or "no" from an answer ("Yes, it is", "<ans>false</ans>"); None when unclear or both."""
    if not text:
        return None
    words = set(re.findall(r"[a-z]+", tagged_answer(text).lower()))
    said_yes, said_no = bool(words & _YES), bool(words & _NO)
    if said_yes == said_no:
        return None
    return "yes" if said_yes else "no"


def normalize_words(text: str | None) -> str:
    """Lower case, no punctuation, no leading article: "The Chair." -> "chair"."""
    words = re.findall(r"[a-z0-9]+", tagged_answer(text or "").lower())
    if words and words[0] in ("a", "an", "the"):
        words = words[1:]
    return " ".join(words)
