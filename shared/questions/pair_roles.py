"""The words that give a mentioned photo its role in the pair a question compares.

A table, not a list of sentences: each row is a phrase (a regular expression over normalized words)
and the role it gives, read by shared/questions/view_pair.py.

- `CUES` govern the photo named *after* them: "from X" (X is the start), "relative to X" (the
  reference), "to X", "until X", "when X was taken" (the end), "after X" (X came first: the start),
  "before X" (X came later: the end), "in the axes of X" (a frame: the start only when nothing
  else names one).
- `role_after` reads the words right *after* a photo: "X was taken first", "X preceded Y", "X was
  followed by Y", "X serves as the reference" (the start); "X was shot later", "X followed Y", "X
  was preceded by Y", "X, the later one" (the end); "X's axes" (a frame).
- `ORDER_WORDS` are words of time or sequence: one in a sentence that names a photo, and that no
  cue or predicate here consumed, orders the photos in a way not read (the pair then abstains).
"""

from __future__ import annotations

import re

# ---- words before a photo -------------------------------------------------------------------

_NOT_FROM = r"(?<!apart )(?<!aside )(?<!away )(?<!far )(?<!different )(?<!differently )(?<!distinct )"
_NOT_TO_BEFORE = (
    r"(?<!next )(?<!close )(?<!closer )(?<!nearer )(?<!similar )(?<!according )(?<!due )(?<!attached )"
    r"(?<!equal )(?<!parallel )(?<!perpendicular )(?<!opposite )(?<!adjacent )(?<!addition )"
)
_SIDE = r"(?:left|right|side|front|back|rear|top|bottom|north|south|east|west|center|centre|middle)"
_NOT_TO_AFTER = rf"(?!\s+(?:the\s+|its\s+|his\s+|her\s+|their\s+|my\s+|your\s+|our\s+)?{_SIDE}\b)(?!\s+be\b)"
_FRAME_NOUN = (
    r"(?:frame of reference|reference frame|coordinate (?:system|frame)|frame|axes|directions|"
    r"coordinates|perspective|point of view|image axes)"
)
_ARRIVE = r"(?:at|in|on|with)"

_CUE_TABLE: tuple[tuple[str, str, bool], ...] = (
    # the start, the reference: the photo after these words is where the camera was first
    (r"(?:compared (?:with|to|against)|relative to|than|from|since|between) (?:when|where|the (?:moment|time)"
     r"s?(?: when| that)?)", "from", False),
    (r"as compared (?:with|to)|compare(?:s|d)? (?:with|to|against)", "from", False),
    (r"in comparison (?:with|to)|by comparison with|in contrast (?:with|to)|contrasted with", "from", False),
    (r"relative(?:ly)? to|with respect to|in respect of|in relation to|with reference to|"
     r"in reference to|referenced to|as opposed to|as against|versus|vs|against|than", "from", False),
    (r"(?:seen|viewed|measured|looking|observed|judged) (?:from|by)", "from", False),
    # a place said of a photo's camera: "to the left of X", "behind X" (X is the reference)
    (rf"{_SIDE} of|in front of|ahead of|behind|above|below|beneath|underneath|higher than|"
     r"lower than|closer than|farther than|further than", "from", False),
    (r"(?:having )?(?:start(?:s|ed|ing)?|beg(?:an|un|ins|inning)|set(?:ting)? off|depart(?:s|ed|ing)?|"
     r"leav(?:e|es|ing)|left off) (?:out )?(?:at|from|with|in|on)|depart(?:s|ed|ing)?|leaving",
     "from", False),
    (r"later than|subsequent to|after|following|since|between|in between", "from", False),
    (r"first (?:came|was|there was|comes)|at first|to begin with|at the (?:start|beginning|outset)|"
     r"initially|originally|previously|earlier(?! than)|first(?! time)", "from", True),
    (_NOT_FROM + r"from", "from", False),
    # the end: the photo after these words is where the camera ended
    (r"earlier than|sooner than|prior to|before|preceding", "to", False),
    (r"(?:and )?then|afterwards?|thereafter|subsequently|later(?! than)|next(?! to)|finally|lastly|"
     r"eventually|in the end|at the end", "to", True),
    (r"back to|over to|on to|onto|on (?:the|its|their) way to|heading (?:to|toward|towards|for)|"
     r"into|towards?|up until|until|till", "to", False),
    (r"when|by the time(?: of| that)?|at the time of|at the moment(?: of)?|once at", "to", False),
    (r"(?:reach(?:es|ed|ing)?|get(?:s|ting)? to|got to|arriv(?:e|es|ed|ing) " + _ARRIVE + ")", "to", False),
    (r"(?:end(?:s|ed|ing)?|finish(?:es|ed|ing)?|stop(?:s|ped|ping)?|conclud(?:es|ed|ing)) (?:up )?"
     + _ARRIVE, "to", False),
    (r"followed by|succeeded by", "to", False),
    (_NOT_TO_BEFORE + r"to" + _NOT_TO_AFTER, "to", False),
    # a frame: whose axes the directions are in
    (rf"{_FRAME_NOUN} of(?: the camera(?: of| that took| for)?)?|(?:as )?seen in", "frame", False),
)  # fmt: skip

CUE_ROLES = tuple(role for _, role, _ in _CUE_TABLE)
CUE_IS_ADVERB = tuple(adverb for _, _, adverb in _CUE_TABLE)
CUES = re.compile(r"\b(?:" + "|".join(f"({phrase})" for phrase, _, _ in _CUE_TABLE) + r")\b")
# Words of time that, said of no photo, still order the photos ("which came first?").
TIME_WORDS = frozenset(
    """first earlier later before after then next previously initially originally finally lastly
    eventually subsequently afterwards afterward thereafter since until till once prior following
    preceding""".split()
)


def cue_role(match: re.Match[str]) -> str:
    """The role a match of `CUES` gives the photo after it."""
    return CUE_ROLES[(match.lastindex or 1) - 1]


def is_adverb(match: re.Match[str]) -> bool:
    """A cue of the whole clause ("then", "initially"): it governs the photo its clause names,
    however many words stand between; a preposition ("from") governs only its own object."""
    return CUE_IS_ADVERB[(match.lastindex or 1) - 1]


# Between a cue and the photo it governs stand only the words of its object ("from where it stood
# for shot 1", "relative to the camera of the last view"); a new clause means the cue had another
# object ("taken from the doorway, and the second ...", "relative to the table, where is photo 2").
_CLAUSE = frozenset("and or but while whereas how what which why who whose did does do if".split())
_PLACE_OF_TIME = frozenset("spot place position location point moment time instant".split())
_MAX_GAP = 8
_COPULA = frozenset("was were is are".split())


def governs(gap: str) -> bool:
    """Whether a cue governs the photo named after `gap`, the words between them."""
    words = gap.split()
    if len(words) > _MAX_GAP or any(w in _CLAUSE for w in words):
        return False
    # "when the camera was at the door, image 1 ...": the clause the cue opened ended before the photo
    if any(w in _COPULA and len(words) - i - 1 >= 3 for i, w in enumerate(words)):
        return False
    return all(
        i == 0 or words[i - 1] in _PLACE_OF_TIME for i, w in enumerate(words) if w in ("where", "when")
    )


# ---- words after a photo --------------------------------------------------------------------

_LEAD = (
    r"^\s*(?:s\s+(?:(?:camera|viewpoint|position|location|vantage point|shooting position)\s+)?)?"
    r"(?:(?:which|that|it)\s+)?(?:(?:was|is|were|are|had been|has been|have been|came|comes|"
    r"come|got|gets|being|been|will be|would be|shows|show|showed|marks|marked|represents|depicts|"
    r"as|serves as|served as|acts as|is used as|was used as|used as|taken as)\s+)?"
    r"(?:(?:taken|shot|captured|made|snapped|recorded|photographed|obtained|acquired|produced|created|done)\s+)?(?:(?:only|just|directly|immediately|"
    r"right|shortly|much|well|some time|sometime|clearly)\s+)?"
)
_ONE = (
    r"(?:\s+(?:one|shot|photo|image|picture|view|frame|snapshot|point|position|location|spot|place|"
    r"of the two|of the pair|view|reference|reference point|frame of reference|capture|exposure))?"
)
_BY_WHOM = r"(?:the camera|it|they|you|we|the photographer|the shooter|i)"
_AFTER_TABLE: tuple[tuple[str, str], ...] = (
    (r"preceded by", "to"),
    (r"(?:followed|succeeded) by", "from"),
    (r"(?:preceded|precedes|precede|predates|predated|came before|comes before|come before|"
     r"led to|leads to|gave way to)\b", "from"),
    (r"(?:followed|follows|follow|succeeded|succeeds|came after|comes after|postdates|postdated)\b", "to"),
    (r"(?:first|earlier(?: than)?|sooner(?: than)?|older(?: than)?|before(?: that| it)?|previously|"
     r"initially|originally|beforehand|at the (?:start|beginning|outset)|to begin with|in the beginning)\b",
     "from"),
    (r"(?:after(?:wards?)?(?: that| it)?|later(?: than| on)?|newer(?: than)?|more recent(?: than)?|"
     r"next(?! to)|second|subsequently|last|finally|thereafter|at the end|in the end|eventually)\b", "to"),
    (r"(?:(?:serves|served|acts|acted|is used|was used|used|taken|being) )?as (?:the |a |its )?"
     r"(?:reference|baseline|origin|anchor|start(?:ing point)?|beginning|base|source|departure(?: point)?)"
     + _ONE + r"\b", "from"),
    (r"(?:(?:serves|served|acts|acted|is used|was used|used|taken|being) )?as (?:the |a |its )?"
     r"(?:end(?:ing)? point|end|destination|target|arrival(?: point)?|finish)" + _ONE + r"\b", "to"),
    (r"(?:the |a |its )(?:earlier|earliest|former|older|initial|starting|start|reference|baseline|before|"
     r"origin|anchor|source|beginning|departure)" + _ONE + r"\b", "from"),
    (r"(?:the |a |its )(?:later|latest|newer|final|end|ending|finishing|target|destination|arrival|after|"
     r"finish)" + _ONE + r"\b", "to"),
    (rf"where {_BY_WHOM} (?:started|began|set off|was first|stood first|departed)\b", "from"),
    (rf"where {_BY_WHOM} (?:ended(?: up)?|finished|stopped|arrived|came to rest|was last)\b", "to"),
)  # fmt: skip
_AFTER = [(re.compile(_LEAD + phrase), role) for phrase, role in _AFTER_TABLE]
_FRAME_AFTER = re.compile(rf"^\s*s\s+(?:own\s+)?{_FRAME_NOUN}\b")


def role_after(words: str, end: int) -> tuple[str | None, int]:
    """(role, where its words end) from the words right after a photo's mention (None, end if none)."""
    rest = words[end:]
    if frame := _FRAME_AFTER.match(rest):
        return "frame", end + frame.end()
    for pattern, role in _AFTER:
        if match := pattern.match(rest):
            return role, end + match.end()
    return None, end


# ---- words of order that no row above reads --------------------------------------------------

ORDER_WORDS = frozenset(
    """prior previous previously preceding precede precedes preceded precedent predecessor
    following follow follows followed subsequent subsequently succeeding succeed succeeds succeeded
    successor after afterwards afterward before beforehand earlier later then next once until till
    since former latter originally initially eventually finally lastly ahead meanwhile while
    whereas start starting started begin began begun beginning end ended ending origin destination
    reference baseline relative compared versus vs between from to than earliest latest sooner
    older newer predate predates predated postdate postdates thereafter order reverse reversed
    reversing comparing compare""".split()
)
# Phrases with an order word that order nothing ("apart from moving", "where it ended up pointing").
# "In that order" and "respectively" keep the order of mention.
NOT_ORDER = re.compile(
    r"\b(?:apart|aside|away|far|different|differently|distinct)\s+from\b|\bend(?:s|ed|ing)?\s+up\b|"
    r"\bin (?:that|this|the same|the given|the listed) order\b|\brespectively\b|\bin order\b|"
    rf"\bto (?:the |its |his |her |their |my |your |our )?{_SIDE}\b|\b(?:next|close|closer|nearer|similar|"
    r"according|due|attached|equal|parallel|perpendicular|opposite|adjacent|addition) to\b"
)

__all__ = ["CUES", "NOT_ORDER", "ORDER_WORDS", "TIME_WORDS", "cue_role", "governs", "is_adverb", "role_after"]
