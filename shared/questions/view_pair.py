"""Which two photos a question compares, and in which order: read from its grammar, never guessed.

Every mention of a view is found (a noun with a number, "image 3", "photo two", "shot #2"; an
ordinal with a noun, "the first picture", "the last frame", "the second one"; a bare ordinal after
"the": "relative to the first"), and given a role by the words around it:

- *from* (the reference, the earlier photo): "from X", "relative to X", "compared with X", "with
  respect to X", "between X and ...", "after X", "since X", "later than X", "X was taken first /
  earlier / before";
- *to* (the photo asked about, the later one): "to X", "back to X", "then X", "until X", "when X
  was taken", "before X", "earlier than X", "X was taken after / later / next".

The pair is (from, to). With no roles, the order of mention ("image 1 ... image 3"). With two
images and one or no view named, the other view completes the pair in time order (1 -> 2) unless a
role says otherwise. Two readings (both views "from", one view both, three views and no roles, a
view beyond the photos given) leave the pair unread, with the reason (`doubt`). So does a word of
time or sequence that no construction here consumed ("prior to", "the former", "subsequent"): the
cues' own "to" or the order of mention would otherwise decide the pair, possibly reversed. And with
two photos, a photo named in a way not read ("the earlier shot") stops the default 1 -> 2.
"""

from __future__ import annotations

import re

from pydantic import BaseModel

from shared.questions.lexicon import normalized

_NOUN = (
    r"(?:images?|views?|pictures?|photos?|photographs?|frames?|shots?|snapshots?|viewpoints?|"
    r"cameras?|pics?|imgs?)"
)
_NUMBER_WORDS = {
    "one": 1, "two": 2, "three": 3, "four": 4, "five": 5,
    "six": 6, "seven": 7, "eight": 8, "nine": 9, "ten": 10,
}  # fmt: skip
_ORDINAL_WORDS = {
    "first": 1, "second": 2, "third": 3, "fourth": 4, "fifth": 5,
    "sixth": 6, "seventh": 7, "eighth": 8, "ninth": 9, "tenth": 10,
    "initial": 1, "opening": 1, "starting": 1, "last": 0, "final": 0, "latter": 0,
}  # fmt: skip
_NUM = r"(?:\d+|" + "|".join(_NUMBER_WORDS) + r")"
_ORD = r"(?:" + "|".join(_ORDINAL_WORDS) + r"|\d+(?:st|nd|rd|th))"
_NUMBERED = re.compile(
    rf"\b{_NOUN}\s*(?:number\s+|no\s+|#\s*)?(?P<n>{_NUM})\b(?P<more>(?:(?:\s*(?:and|to|through|or|"
    rf"vs|versus)\s*|\s+){_NUM}\b)*)"
)
_ADJECTIVE = (
    r"(?:captured|taken|input|given|original|camera|photographed|still|video|key|shown|reference|numbered)"
)
_ORDINAL_NOUN = re.compile(rf"\b(?P<o>{_ORD})\s+(?:{_ADJECTIVE}\s+)?(?:{_NOUN}|one)\b")
_BARE_ORDINAL = re.compile(
    rf"\bthe\s+(?P<o>{_ORD})\b(?!\s+(?:{_ADJECTIVE}\s+)?(?:{_NOUN}|one)\b)(?=\s*(?:$|and|to|"
    rf"[a-z]+ (?:was|is)|[?,.]|\b))"
)
_OTHER = re.compile(rf"\bthe other\s+(?:{_NOUN}|one)\b")

# The words that give the view after them a role; the last of them between the previous mention and
# this one counts ("compared with where it stood for shot one": shot one is the reference).
_CUES = re.compile(
    r"\b(?:(?P<to_first>earlier than|sooner than|before)|(?P<from_first>later than|after|since)|"
    r"(?P<from>(?<!apart )(?<!aside )(?<!away )(?<!far )(?<!different )from|relative to|"
    r"compared (?:with|to)|comparing|in comparison (?:with|to)|with respect to|"
    r"in relation to|versus|vs|leaving|starting (?:at|from|with)|seen from|against|with reference to|"
    r"departing|between|than|first came|first was|first there was|taken first)|"
    r"(?P<to>back to|to|into|toward|towards|until|till|reaching|then|when|by the time|arriving at|"
    r"ending (?:at|in|with)|got to|finally|lastly))\b"
)
_FROM_AFTER = re.compile(
    r"^\s*(?:s\s+)?(?:(?:was|is|were|came)\s+)?(?:(?:taken|shot|captured|made|snapped)\s+)?"
    r"(?:first|earlier|before)\b"
    r"|^\s*(?:s\s+)?as\s+(?:the\s+|a\s+|its\s+)?(?:reference|baseline|origin|starting point|start)\b"
)
_TO_AFTER = re.compile(
    r"^\s*(?:s\s+)?(?:(?:was|is|were|came)\s+)?(?:(?:taken|shot|captured|made|snapped)\s+)?"
    r"(?:after|later|afterwards|next|second|followed)\b|^\s*followed\b"
)


_SENTENCES = re.compile(r"(?<=[.!?;])\s+(?=[A-Z])|;\s*")

# Words of time and sequence: each can order two photos. One that no construction above consumed
# ("prior to", "preceding", "subsequent", "the former") orders them in a way this reader does not
# know, so the pair it would read is in doubt: unread, never guessed (the cues' own "to" or the
# order of mention would otherwise decide it, possibly reversed).
_ORDER_WORDS = frozenset(
    """prior previous previously preceding precede precedes preceded precedent predecessor
    following follow follows followed subsequent subsequently succeeding succeed succeeds succeeded
    successor after afterwards afterward before beforehand earlier later then next once until till
    since former latter originally initially eventually finally lastly ahead meanwhile while
    whereas start starting started begin began begun beginning end ended ending origin destination
    reference baseline relative compared versus vs between from to than""".split()
)
_WORD = re.compile(r"[a-z]+")
# With no view read, these still point at one photo ("the earlier shot", "the former picture",
# "photo B"): two photos then are not "1 to 2 by default", the question names them in a way not read.
_ONE_PHOTO = re.compile(
    r"\b(?:the|this|that|a|an|another|other|which|each)\s+(?:[a-z]+\s+)?"
    r"(?:image|view|picture|photo|photograph|frame|shot|snapshot|pic|img)\b(?!\s+of\b)"
    r"|\b(?:prior|previous|preceding|following|subsequent|succeeding|earlier|later|former|latter|next|"
    r"initial|original|final|first|second|last)\b"
)
# Phrases with an order word that order nothing ("apart from moving", "where it ended up pointing").
_NOT_ORDER = re.compile(
    r"\b(?:apart|aside|away|far|different|differently|distinct)\s+from\b|\bend(?:s|ed|ing)?\s+up\b"
)


class PairReading(BaseModel, frozen=True):
    views: tuple[int, int] | None = None
    view_set: tuple[int, ...] = ()
    source: str = ""
    certain: bool = False
    doubt: str | None = None


def _value(word: str, image_count: int | None) -> int | None:
    if word.isdigit():
        return int(word)
    if word in _NUMBER_WORDS:
        return _NUMBER_WORDS[word]
    if word in _ORDINAL_WORDS:
        value = _ORDINAL_WORDS[word]
        return value if value else image_count
    return int(re.match(r"\d+", word).group())  # type: ignore[union-attr]


def _mentions(text: str, image_count: int | None) -> list[tuple[int, int, int | None]]:
    """(start, end, view) of every mention, in order; view None for "the last" with no count."""
    found: list[tuple[int, int, int | None]] = []
    for match in _NUMBERED.finditer(text):
        found.append((match.start(), match.end("n"), _value(match.group("n"), image_count)))
        for extra in re.finditer(_NUM, match.group("more") or ""):
            start = match.start("more") + extra.start()
            found.append((start, start + len(extra.group()), _value(extra.group(), image_count)))
    for pattern in (_ORDINAL_NOUN, _BARE_ORDINAL):
        for match in pattern.finditer(text):
            if not any(s <= match.start("o") < e for s, e, _ in found):
                found.append((match.start(), match.end(), _value(match.group("o"), image_count)))
    return sorted(found)


def _role(text: str, start: int, end: int, previous_end: int) -> str | None:
    """ "from", "to" or None for the mention text[start:end], from the last cue before it (back to the
    previous mention) or, failing that, the words right after it ("shot 3 was taken earlier")."""
    previous_end = max(previous_end, text.rfind(" . ", 0, start) + 1)
    cues = list(_CUES.finditer(text, previous_end, start))
    if cues:
        last = cues[-1]
        return "to" if last.group("to_first") or last.group("to") else "from"
    after = text[end:]
    if _FROM_AFTER.match(after):
        return "from"
    if _TO_AFTER.match(after):
        return "to"
    return None


def read_pair(text: str, image_count: int | None = None, default_two: bool = False) -> PairReading:
    """The ordered pair a text names (see the module docstring)."""
    # Sentence by sentence, with " . " between them: a cue never reaches across a sentence.
    words = " . ".join(normalized(sentence) for sentence in _SENTENCES.split(text or ""))
    mentions = _mentions(words, image_count)
    if any(view is None for _, _, view in mentions):
        return PairReading(doubt="it names the last photo, and the number of photos is not known")
    views = tuple(dict.fromkeys(view for _, _, view in mentions))  # type: ignore[misc]
    if image_count is not None and any(not 1 <= v <= image_count for v in views):
        return PairReading(view_set=views, doubt=f"it names a photo beyond the {image_count} given")
    roles: dict[int, set[str]] = {}
    previous_end = 0
    for start, end, view in mentions:
        role = _role(words, start, end, previous_end)
        previous_end = end
        roles.setdefault(view, set())  # type: ignore[arg-type]
        if role:
            roles[view].add(role)  # type: ignore[index]
    source = " / ".join(words[s:e] for s, e, _ in mentions)
    unknown = _unread_order_words(words, mentions)
    if unknown and len(views) >= 1:
        return PairReading(
            view_set=views,
            doubt=f"the words {', '.join(repr(w) for w in unknown)} order the photos in a way not read",
        )
    other = _OTHER.search(words)
    if len(views) == 1 and other and image_count == 2:
        views = (*views, 3 - views[0])
        roles[views[1]] = set()
    named = _ONE_PHOTO.search(words) if not views and default_two and image_count == 2 else None
    if named:
        return PairReading(doubt=f"it names a photo ('{named.group()}') in a way not read")
    return _ordered(views, roles, image_count, default_two, source)


def _unread_order_words(words: str, mentions: list[tuple[int, int, int | None]]) -> list[str]:
    """Order words in the sentences that name a view, outside every cue and mention that was read."""
    consumed = [(s, e) for s, e, _ in mentions]
    consumed += [(m.start(), m.end()) for m in (*_CUES.finditer(words), *_NOT_ORDER.finditer(words))]
    for _, end, _view in mentions:
        for pattern in (_FROM_AFTER, _TO_AFTER):
            after = pattern.match(words[end:])
            if after:
                consumed.append((end, end + after.end()))
    for match in (*_ORDINAL_NOUN.finditer(words), *_BARE_ORDINAL.finditer(words), *_OTHER.finditer(words)):
        consumed.append((match.start(), match.end()))
    spans = [(s, e) for s, e, _ in mentions]
    sentences = [
        sentence
        for sentence in _sentence_spans(words)
        if any(s0 <= a < s1 for a, _ in spans for s0, s1 in [sentence])
    ]
    unread = []
    for start, end in sentences:
        for word in _WORD.finditer(words, start, end):
            if word.group() in _ORDER_WORDS and not any(a <= word.start() < b for a, b in consumed):
                unread.append(word.group())
    return list(dict.fromkeys(unread))


def _sentence_spans(words: str) -> list[tuple[int, int]]:
    bounds = [0] + [m.end() for m in re.finditer(r" \. ", words)] + [len(words) + 3]
    return [(a, b - 3) for a, b in zip(bounds, bounds[1:], strict=False) if b - 3 > a]


def _ordered(
    views: tuple[int, ...],
    roles: dict[int, set[str]],
    image_count: int | None,
    default_two: bool,
    source: str,
) -> PairReading:
    if any(len(r) > 1 for r in roles.values()):
        return PairReading(
            view_set=views,
            doubt="a photo is named both as the start and as the end: two readings of the pair",
        )
    sources = [v for v in views if roles[v] == {"from"}]
    targets = [v for v in views if roles[v] == {"to"}]
    if len(sources) > 1 or len(targets) > 1:
        return PairReading(
            view_set=views,
            doubt="two photos are each named as the start (or the end): two readings of the pair",
        )
    if not views:
        if default_two and image_count == 2:
            return PairReading(views=(1, 2), source="two photos, no pair named: 1 to 2", certain=True)
        return PairReading(
            doubt=None if not default_two else "it names no photos and there are more than two"
        )
    if len(views) == 1:
        return _one_named(views[0], sources, targets, image_count, source)
    if len(views) > 2 and not (sources and targets):
        return PairReading(
            view_set=views, doubt=f"it names {len(views)} photos without saying which two it compares"
        )
    first = sources[0] if sources else None
    last = targets[0] if targets else None
    if first is None:
        first = next(v for v in views if v != last)
    if last is None:
        last = next(v for v in views if v != first)
    how = "its words" if sources or targets else "the order of mention"
    return PairReading(views=(first, last), view_set=views, source=f"{source} ({how})", certain=True)


def _one_named(
    view: int, sources: list[int], targets: list[int], image_count: int | None, source: str
) -> PairReading:
    if image_count != 2:
        return PairReading(
            view_set=(view,), doubt="it names one photo and does not say which other it is compared with"
        )
    other = 3 - view
    if sources:
        pair = (view, other)
    elif targets:
        pair = (other, view)
    else:
        pair = (1, 2)  # two photos, one named without a role: in the order they were taken
    return PairReading(
        views=pair, view_set=(view,), source=f"{source} (the other of two photos)", certain=True
    )


__all__ = ["PairReading", "read_pair"]
