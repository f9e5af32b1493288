"""Which two photos a question compares, and in which order: read from its grammar, never guessed.

Every mention of a photo is found: a noun with a number ("image 3", "photo two", "shot #2", "frame
no. 4", "exposure number one", "the picture numbered 3", "images 2 and 3"), an ordinal with a noun
("the first picture", "the 3rd shot", "the last frame", "the second one"), a bare ordinal
("relative to the first"), "the other one" (with two photos and one named), "the former" / "the
latter" (the two photos named just before). An opening roll call of every photo ("Given image 1,
image 2 and image 3, ...") names the set, not the pair. Each mention then gets a *role* from the
words that govern it (the table is shared/questions/pair_roles.py):

- *from* (the reference, the photo the camera started at): the word before it ("from", "relative
  to", "compared with", "against", "than", "behind", "since", "after", "following", "subsequent
  to", "leaving", "starting at", "seen from", "initially") or the words after it ("X was taken
  first", "X preceded Y", "X was followed by Y", "X serves as the reference", "X, the earlier one");
- *to* (the photo asked about, where the camera ended): "to", "into", "toward", "until", "when",
  "by the time", "reaching", "arriving at", "ending at", "then", "afterwards", "before", "prior
  to", "earlier than"; after it, "X was taken after / later / next / second", "X followed Y", "X was
  preceded by Y", "X, the later one";
- *frame* (a weak from): "in X's axes", "the frame of X", "from the perspective of X": the photo
  whose axes are meant is the reference only when no other word names one.

A preposition governs only its own object ("taken from the doorway and the second ..." gives the
second photo no role); an adverb of time ("then", "initially") governs its clause. The words right
after a mention are read first and are spent on it, so "X was taken before Y" gives X its role and
leaves Y the other place. The pair is (from, to); a photo with no role takes the place left. With
no role at all, only photos listed side by side ("between X and Y", "images 1 and 3") keep their
order of mention: in other words the photo asked about often comes first ("where is B, standing
at A?"), so the order of mention is no guide. With two photos and one or no photo named, the other
photo completes the pair in time order (1 -> 2) unless a role says otherwise. Two readings (both
photos "from", one photo both, three photos and no roles, a photo beyond those given, a round
trip) leave the pair unread, with the reason (`doubt`). So does a word of time or sequence that
gave no photo a role ("once", "the former" with nothing before it, "in reverse order", "which came
first?"): the cues' own "to" or the order of mention would otherwise decide the pair, possibly
reversed. And with two photos, a photo named in a way not read ("the earlier shot", "photo B")
stops the default 1 -> 2.
"""

from __future__ import annotations

import re

from pydantic import BaseModel

from shared.questions.lexicon import normalized
from shared.questions.pair_roles import (
    CUES,
    NOT_ORDER,
    ORDER_WORDS,
    TIME_WORDS,
    cue_role,
    governs,
    is_adverb,
    role_after,
)

_NOUN = (
    r"(?:images?|views?|pictures?|photos?|photographs?|frames?|shots?|snapshots?|snaps?|viewpoints?|"
    r"cameras?|pics?|imgs?|captures?|exposures?|stills?|takes?)"
)
_NUMBER_WORDS = {
    "one": 1, "two": 2, "three": 3, "four": 4, "five": 5,
    "six": 6, "seven": 7, "eight": 8, "nine": 9, "ten": 10,
}  # fmt: skip
_ORDINAL_WORDS = {
    "first": 1, "second": 2, "third": 3, "fourth": 4, "fifth": 5,
    "sixth": 6, "seventh": 7, "eighth": 8, "ninth": 9, "tenth": 10,
    "initial": 1, "opening": 1, "starting": 1, "last": 0, "final": 0, "closing": 0,
    "concluding": 0,
}  # fmt: skip
_NUM = r"(?:\d+|" + "|".join(_NUMBER_WORDS) + r")"
_ORD = r"(?:" + "|".join(_ORDINAL_WORDS) + r"|\d+(?:st|nd|rd|th))"
_NUMBERED = re.compile(
    rf"\b{_NOUN}\s*(?:(?:number|no|nr|num|index|idx|numbered|labell?ed|marked|tagged|called|named)\s+)?(?P<n>{_NUM})\b(?!\s*(?:°|degrees?\b|m\b|cm\b|meters?\b|metres?\b|"
    rf"steps?\b|times?\b))(?P<more>(?:(?:\s*(?:and|to|through|or|vs|versus)\s*|\s+){_NUM}\b)*)"
)
_ADJECTIVE = (
    r"(?:captured|taken|input|given|original|camera|photographed|still|video|key|shown|reference|numbered)"
)
_ORDINAL_NOUN = re.compile(rf"\b(?P<o>{_ORD})\s+(?:{_ADJECTIVE}\s+)?(?:{_NOUN}|one)\b")
# "the third" with no noun after it names a photo ("from the first picture to the third"), unless a
# noun of something else follows ("the first time", "the first two images").
_BARE_ORDINAL = re.compile(
    rf"\bthe\s+(?P<o>{_ORD})\b(?!\s+(?:{_ADJECTIVE}\s+)?(?:{_NOUN}|one)\b)(?!\s+(?:{_NUM}|time|times|"
    r"step|steps|stage|move|moves|motion|turn|turns|half|part|thing|place|position|option|answer|"
    r"question|person|object|row|column|case|pair|two|few|couple)\b)"
)
# "image 2 is the starting view", "taking image 3 as the final frame": an ordinal said of a photo
# already named gives it a role (shared/questions/pair_roles.py), it names no photo of its own.
_PREDICATE = re.compile(
    r"\s*(?:s\s+(?:camera|viewpoint|position)\s+)?(?:is|was|are|were|be|being|been|as|shows|marks|"
    r"represents)\s+(?:the\s+|a\s+|its\s+)?"
)
_OTHER = re.compile(rf"\bthe other\s+(?:{_NOUN}|one)\b")
_ANAPHOR = re.compile(rf"\bthe (former|latter)\b(?:\s+(?:{_NOUN}|one)\b)?")
_OTHER_VIEW = -1  # a mention of "the other one", resolved once the named photo is known
_UNKNOWN_LAST = 0  # "the last" when the number of photos is not known


class PairReading(BaseModel, frozen=True):
    views: tuple[int, int] | None = None
    view_set: tuple[int, ...] = ()
    source: str = ""
    certain: bool = False
    doubt: str | None = None
    by_words: bool = False  # a word gave a photo its role (not the order of mention nor a default)


def _value(word: str, image_count: int | None) -> int:
    if word.isdigit():
        return int(word)
    if word in _NUMBER_WORDS:
        return _NUMBER_WORDS[word]
    if word in _ORDINAL_WORDS:
        value = _ORDINAL_WORDS[word]
        return value if value else (image_count or _UNKNOWN_LAST)
    return int(re.match(r"\d+", word).group())  # type: ignore[union-attr]


def _mentions(text: str, image_count: int | None) -> list[tuple[int, int, int]]:
    """(start, end, view) of every mention, in order (view -1: "the other one", 0: "the last" with
    no count)."""
    found: list[tuple[int, int, int]] = []
    for match in _NUMBERED.finditer(text):
        found.append((match.start(), match.end("n"), _value(match.group("n"), image_count)))
        for extra in re.finditer(_NUM, match.group("more") or ""):
            start = match.start("more") + extra.start()
            found.append((start, start + len(extra.group()), _value(extra.group(), image_count)))
    for pattern in (_ORDINAL_NOUN, _BARE_ORDINAL):
        for match in pattern.finditer(text):
            # "first image 2": the number names the photo, "first" is a word of sequence
            overlaps = any(s < match.end() and match.start() < e for s, e, _ in found)
            said_of = any(
                _PREDICATE.fullmatch(text, e, match.start()) for s, e, _ in found if e <= match.start()
            )
            if not overlaps and not said_of:
                found.append((match.start(), match.end(), _value(match.group("o"), image_count)))
    for match in _OTHER.finditer(text):
        found.append((match.start(), match.end(), _OTHER_VIEW))
    for match in _ANAPHOR.finditer(text):
        # "the former" / "the latter" after two photos are those two; "the latter photo" with none
        # before it is the last; "the former" with none before it names no photo (left unread)
        before = list(dict.fromkeys(v for s, _, v in sorted(found) if s < match.start() and v > 0))
        if len(before) >= 2:
            found.append(
                (match.start(), match.end(), before[-2] if match.group(1) == "former" else before[-1])
            )
        elif match.group(1) == "latter":
            found.append((match.start(), match.end(), image_count or _UNKNOWN_LAST))
    return sorted(found)


def views_mentioned(text: str, image_count: int | None = None) -> tuple[int, ...]:
    """Every photo a text names by number or ordinal, in order of mention, whatever its role ("in the
    frame of image 1" names image 1, though as a frame it names no pair)."""
    mentions = _mentions(_words(text), image_count)
    return tuple(dict.fromkeys(view for _, _, view in mentions if view > 0))


def read_pair(text: str, image_count: int | None = None, default_two: bool = False) -> PairReading:
    """The ordered pair a text names (see the module docstring)."""
    words = _words(text)
    mentions = _mentions(words, image_count)
    if any(view == _UNKNOWN_LAST for _, _, view in mentions):
        return PairReading(doubt="it names the last photo, and the number of photos is not known")
    named = tuple(dict.fromkeys(v for _, _, v in mentions if v != _OTHER_VIEW))
    if image_count is not None and any(not 1 <= v <= image_count for v in named):
        return PairReading(view_set=named, doubt=f"it names a photo beyond the {image_count} given")
    if any(v == _OTHER_VIEW for _, _, v in mentions):
        if image_count != 2 or len(named) != 1:
            return PairReading(view_set=named, doubt="it names 'the other' photo in a way not read")
        mentions = [(s, e, 3 - named[0] if v == _OTHER_VIEW else v) for s, e, v in mentions]
    mentions = _without_roll_call(words, mentions, image_count)
    roles, consumed = _roles(words, mentions)
    views = tuple(dict.fromkeys(v for _, _, v in mentions))
    source = " / ".join(words[s:e] for s, e, _ in mentions)
    asking = [asks for _, asks in _pieces(text)]
    unknown = _unread_order_words(words, mentions, consumed, asking)
    if views and (trip := _ROUND_TRIP.search(words)):
        return PairReading(view_set=views, doubt=f"it says '{trip.group()}': a round trip, not one pair")
    if unknown and views:
        return PairReading(
            view_set=views,
            doubt=f"the words {', '.join(repr(w) for w in unknown)} order the photos in a way not read",
        )
    one_photo = _ONE_PHOTO.search(words) if not views and default_two and image_count == 2 else None
    if one_photo:
        return PairReading(doubt=f"it names a photo ('{one_photo.group()}') in a way not read")
    listed = len(views) == 2 and _LISTED.fullmatch(words, mentions[0][1], mentions[-1][0]) is not None
    return _ordered(views, roles, image_count, default_two, source, listed)


def _without_roll_call(
    words: str, mentions: list[tuple[int, int, int]], image_count: int | None
) -> list[tuple[int, int, int]]:
    """The mentions without an opening list of every photo ("Given image 1, image 2 and image 3,
    how did the camera move from image 2 to image 3?"): it names the set, not the pair."""
    run = 1
    while run < len(mentions) and _LISTED.fullmatch(words, mentions[run - 1][1], mentions[run][0]):
        run += 1
    listed = {view for _, _, view in mentions[:run]}
    if not image_count or image_count < 3 or run < 2 or listed != set(range(1, image_count + 1)):
        return mentions
    opening = words[words.rfind(" . ", 0, mentions[0][0]) + 1 : mentions[0][0]]
    if len(mentions) > run and not CUES.search(opening):  # "between image 1, 2 and 3" is no roll call
        return mentions[run:]
    return mentions


def _words(text: str) -> str:
    """Sentence by sentence, normalized, with " . " between them (a role never reaches across a
    sentence); arrows read as "to"."""
    return " . ".join(words for words, _ in _pieces(text))


def _pieces(text: str) -> list[tuple[str, bool]]:
    """(normalized words, whether it asks) of each sentence or clause after a colon."""
    text = re.sub(r"\s*(?:->|=>|→|⟶|➔)\s*", " to ", text or "")
    text = re.sub(r"\b(no|nr|num)\.\s*(?=\d)", r"\1 ", text, flags=re.IGNORECASE)  # "photo No.2"
    pieces = [(normalized(piece), piece.rstrip().endswith("?")) for piece in _SENTENCES.split(text)]
    return [(words, asks) for words, asks in pieces if words]


def _roles(
    words: str, mentions: list[tuple[int, int, int]]
) -> tuple[dict[int, set[str]], list[tuple[int, int]]]:
    """Each view's roles ("from", "to", "frame"), and the spans of words that gave them (a word of
    time that gave no photo its role is left out of them: "which came first?")."""
    roles: dict[int, set[str]] = {view: set() for _, _, view in mentions}
    consumed: list[tuple[int, int]] = []
    window_start = 0
    for start, end, view in mentions:
        sentence_start = words.rfind(" . ", 0, start) + 1
        window_start = max(window_start, sentence_start)
        cues = list(CUES.finditer(words, window_start, start))
        before = _governing_role(words, cues, start)
        consumed += [(c.start(), c.end()) for c in cues if before == cue_role(c) or not _timely(c)]
        after, after_end = role_after(words, end)
        if after_end > end:
            consumed.append((end, after_end))
        window_start = max(end, after_end)
        if after == "frame" and before == "from":
            before = None  # "from image 2's point of view": the frame's photo
        for role in (before, after):
            if role:
                roles[view].add(role)
    # words after the last photo of each sentence: only those that order nothing are spent
    consumed += [(c.start(), c.end()) for c in CUES.finditer(words) if not _timely(c)]
    return roles, consumed


def _governing_role(words: str, cues: list[re.Match[str]], start: int) -> str | None:
    """The role the cues before a photo give it: the last one's, when it governs the photo."""
    if not cues:
        return None
    last = cues[-1]
    if len(cues) > 1 and _NESTED_WHEN.fullmatch(last.group()) and _OPENS_CLAUSE.search(cues[-2].group()):
        # "relative to where it was when it took image 1": the "when" is inside the reference
        if cue_role(cues[-2]) == "from" and governs(words[cues[-2].end() : last.start()].replace("when", "")):
            return "from"
    if is_adverb(last) or governs(words[last.end() : start]):
        return cue_role(last)
    return None


_NESTED_WHEN = re.compile(r"when|by the time(?: of| that)?|at the time of|at the moment(?: of)?")
_OPENS_CLAUSE = re.compile(r"(?:where|when|moment|time|times|that)$")


def _timely(cue: re.Match[str]) -> bool:
    """A cue that is a word of time ("first", "then", "before"): one that gives no photo a role
    still orders the photos, in a way not read."""
    return cue.group().split()[0] in TIME_WORDS


_SENTENCES = re.compile(r"(?<=[.!?;])\s+(?=[A-Z])|(?<=[?:])\s+|;\s*")
_WORD = re.compile(r"[a-z]+")
_ROUND_TRIP = re.compile(r"\b(?:and back(?: again)?|back and forth|there and back|to and fro|round trip)\b")
# With no view read, these still point at one photo ("the earlier shot", "the former picture",
# "photo B"): two photos then are not "1 to 2 by default", the question names them in a way not read.
_ONE_PHOTO = re.compile(
    r"\b(?:the|this|that|a|an|another|other|which|each)\s+(?:[a-z]+\s+)?"
    r"(?:image|view|picture|photo|photograph|frame|shot|snapshot|pic|img|capture|exposure|snap)\b"
    r"(?!\s+of\b)"
    r"|\b(?:images?|views?|pictures?|photos?|photographs?|frames?|shots?|snapshots?|pics?|imgs?)\s+[a-h]\b"
    r"|\b(?:prior|previous|preceding|following|subsequent|succeeding|earlier|later|former|latter|next|"
    r"initial|original|final|first|second|last)\b"
)


def _unread_order_words(
    words: str, mentions: list[tuple[int, int, int]], consumed: list[tuple[int, int]], asking: list[bool]
) -> list[str]:
    """Order words in the sentences that name a view or ask ("which came first?"), outside every
    cue and mention that was read."""
    spans = [(s, e) for s, e, _ in mentions] + consumed
    spans += [(m.start(), m.end()) for m in NOT_ORDER.finditer(words)]
    for match in (*_ORDINAL_NOUN.finditer(words), *_BARE_ORDINAL.finditer(words), *_OTHER.finditer(words)):
        spans.append((match.start(), match.end()))
    sentences = [
        (a, b)
        for (a, b), asks in zip(_sentence_spans(words), asking, strict=False)
        if asks or any(a <= start < b for start, _, _ in mentions)
    ]
    unread = []
    for start, end in sentences:
        for word in _WORD.finditer(words, start, end):
            if word.group() in ORDER_WORDS | TIME_WORDS and not any(a <= word.start() < b for a, b in spans):
                unread.append(word.group())
    return list(dict.fromkeys(unread))


def _sentence_spans(words: str) -> list[tuple[int, int]]:
    bounds = [0] + [m.end() for m in re.finditer(r" \. ", words)] + [len(words) + 3]
    return [(a, b - 3) for a, b in zip(bounds, bounds[1:], strict=False) if b - 3 > a]


# Two photos listed side by side ("image 1 and image 2", "images 1 and 3", "photos 2, 4"): with no
# word of order, the list's order is the pair's. Two photos in other words with no role between them
# ("where would you find image 2's camera, standing at image 1's?") are in no order that was read: the
# one asked about often comes first ("where is B ...?"), so the order of mention is no guide there.
_LISTED = re.compile(r"\s*(?:and|or|vs|versus|as well as|plus)?\s*")


def _set_frames_apart(
    views: tuple[int, ...], roles: dict[int, set[str]]
) -> tuple[tuple[int, ...], dict[int, set[str]], list[int]]:
    """(views, roles without "frame", the photos named as the frame of the axes)."""
    frames = [v for v in views if "frame" in roles[v]]
    roles = {v: r - {"frame"} for v, r in roles.items()}
    if frames and all(v in frames and not roles[v] for v in views):
        views = ()  # "which way did it move, as seen in image 2?": a note on the axes names no pair
    return views, roles, frames


def _start_and_end(views: tuple[int, ...], sources: list[int], targets: list[int]) -> tuple[int, int]:
    """The pair from the start and end said; the other named photo fills the role not said."""
    first = sources[0] if sources else None
    last = targets[0] if targets else None
    if first is None:
        first = next(v for v in views if v != last)
    if last is None:
        last = next(v for v in views if v != first)
    return first, last


def _ordered(
    views: tuple[int, ...],
    roles: dict[int, set[str]],
    image_count: int | None,
    default_two: bool,
    source: str,
    listed: bool = True,
) -> PairReading:
    views, roles, frames = _set_frames_apart(views, roles)
    if any(len(r) > 1 for r in roles.values()):
        return PairReading(
            view_set=views,
            doubt="a photo is named both as the start and as the end: two readings of the pair",
        )
    if frames and not any(r == {"from"} for r in roles.values()):
        # the photo whose axes are meant is the reference when no other word names one
        unroled = [v for v in frames if not roles[v]]
        if len(unroled) == 1:
            roles[unroled[0]] = {"from"}
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
    if len(views) > 2:  # "from image 1 via image 2 to image 3": the start and the end are said
        views = tuple(v for v in views if v in (*sources, *targets))
    if not sources and not targets and not listed:
        if default_two and image_count == 2:  # the two photos, in no order said: as they were taken
            return PairReading(
                views=(1, 2), view_set=views, source="two photos named in no order: 1 to 2", certain=True
            )
        return PairReading(view_set=views, doubt="it names two photos, and no word says which is the start")
    first, last = _start_and_end(views, sources, targets)
    how = "its words" if sources or targets else "the order of mention"
    return PairReading(
        views=(first, last),
        view_set=views,
        source=f"{source} ({how})",
        certain=True,
        by_words=bool(sources or targets),
    )


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
        views=pair,
        view_set=(view,),
        source=f"{source} (the other of two photos)",
        certain=True,
        by_words=bool(sources or targets),
    )


__all__ = ["ORDER_WORDS", "PairReading", "read_pair", "views_mentioned"]
