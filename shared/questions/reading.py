"""One typed reading of a camera question, made once and carried to every stage.

`read_question(text, image_count)` gives a `QuestionReading`:

- ``views``: the ordered pair (from, to), 1-based, read from the grammar of the stem
  (shared/questions/view_pair.py); ``view_set`` every view the ask names;
- ``quantity``: what is asked: camera translation, rotation, position (of the second camera's
  centre in the first camera's frame), motion (several kinds at once), still, an object relation,
  or other;
- ``frame``: whose axes the directions are in (a view's image axes, the room, an object);
- ``options``: each option as a typed claim (shared/questions/claims.py), read by the lexicon
  (shared/questions/lexicon.py);
- for each slot the words it came from (``*_source``) and whether it is certain (``*_certain``);
- ``abstain_reason``: why no answer may be given whatever the measurement says (two readings of the
  pair, an option that reads two ways, an unread option, stem and options disagreeing), else None;
- ``summary``: "read as: camera rotation from image 1 to image 3, in image 1's axes".

Options lead: when every option reads as a camera claim, the question is a camera question whatever
its stem says, and the claims' kinds are the quantity asked; the stem then only gives the pair. A
bare direction ("Left") means what the stem asks ("turn" makes it a yaw). Everyday verbs ("move",
"go") fix no quantity: people move a camera by turning it too. When the options read only in part and
the stem says no quantity with a word of one kind, what the options are known to state is the
quantity, never certainly: the read ones' kinds, the kinds the unread ones' verbs name ("It rolled
toward the clock's hands" is a turn, its sense unread), and a step for a bare direction beside turns.
A note on directions that names one photo ("Directions are those of image 2.") names the frame.
"""

from __future__ import annotations

import re
from typing import Literal

from pydantic import BaseModel, Field

from shared.questions.choices import split_options
from shared.questions.claims import (
    Bare,
    Claim,
    Unread,
    claim_kinds,
    is_read,
    resolve_bare,
)
from shared.questions.lexicon import kinds_named, normalized, read_phrase, stem_senses, views_named
from shared.questions.view_pair import PairReading, read_pair, views_mentioned

Quantity = Literal["translation", "rotation", "position", "motion", "still", "object_relation", "other"]
CAMERA_QUANTITIES: tuple[Quantity, ...] = ("translation", "rotation", "position", "motion", "still")


class FrameReading(BaseModel, frozen=True):
    """Whose axes the question's directions are in."""

    kind: Literal["view_axes", "room", "object"]
    view: int | None = Field(None, description="view_axes: the 1-based view whose image axes are meant.")
    object: str | None = Field(None, description="object: the object named.")


class QuestionReading(BaseModel, frozen=True):
    text: str = Field("", exclude=True, description="The question as asked.")
    image_count: int | None = None
    views: tuple[int, int] | None = Field(None, description="(from, to), 1-based; None when not read.")
    view_set: tuple[int, ...] = Field((), description="Every view the ask names, in order of mention.")
    views_source: str = ""
    views_certain: bool = False
    quantity: Quantity = "other"
    quantity_source: str = ""
    quantity_certain: bool = False
    frame: FrameReading | None = None
    frame_source: str = ""
    frame_certain: bool = False
    options: dict[str, Claim] = Field(default_factory=dict)
    abstain_reason: str | None = None
    summary: str = ""

    @property
    def is_camera(self) -> bool:
        return self.quantity in CAMERA_QUANTITIES

    @property
    def options_lead(self) -> bool:
        """Every option reads as a camera claim (a bare direction does not)."""
        return bool(self.options) and all(is_read(claim) for claim in self.options.values())

    @property
    def certain(self) -> bool:
        return self.views_certain and self.quantity_certain and self.abstain_reason is None


# ---- the quantity the stem asks ---------------------------------------------------------------

_APART_FROM = re.compile(
    r"\b(?:apart from|aside from|besides|other than|except for|ignoring|setting aside|leaving aside|"
    r"putting aside|leaving out|not counting|regardless of|without counting|excluding|disregarding|"
    r"without (?:considering|regard to|taking into account|counting|looking at)|not considering|"
    r"irrespective of|discounting|neglecting|never mind|no matter|forget(?:ting)?(?: about)?)\s+"
    r"(?P<what>[^,?;.:]+)|"
    # the same set aside after its noun: "Rotation aside, where did it go?"
    r"(?:^|[,;:.]\s*)(?P<before>[a-z' ]{3,40}?)\s+(?:aside|apart|notwithstanding)\s*(?=,)|"
    # "leaving its orientation out of it"
    r"\bleaving (?P<out>[a-z' ]{3,40}?) out(?: of (?:it|account|the question))?\b",
    re.IGNORECASE,
)
_NOUNS = r"(?:images?|photos?|pictures?|views?|frames?|shots?|snapshots?)"
# "where" that asks ("Where was photo 2 taken?"), not one that builds the pair ("from where photo 1
# was taken to where photo 2 was taken").
_WHERE = r"(?<!\bfrom )(?<!\bto )(?<!\bthan )(?<!\bwith )(?<!\bof )(?<!\bat )(?<!\band )\bwhere\b"
_POSITION_ASK = re.compile(
    rf"{_WHERE}[^?]*\b(?:taken|shot|captured|photographed|snapped|located|positioned|placed|situated|stand|"
    r"stands|stood|standing|sit|sits|sat|was the camera|is the camera|were the cameras|camera|photographer|"
    r"shooter|viewer|viewpoint|vantage point|standpoint|spot)\b|"
    # "From where was image 2 shot?", "image 2 was taken from where?"
    r"^(?:from|out of) where\b|\b(?:taken|shot|captured|photographed|snapped) from where\b|"
    r"\blocate\b[^?]*\b(?:camera|photographer|shooter)\b|\b(?:from )?which side\b|"
    r"\bdirection from (?:the )?(?:camera|photographer|shooter|\w+ \w+ s camera|\w+ \w+ camera)\b|"
    r"\b(?:is|was|lies|lay|stands|stood|sits|sat) where\b|"
    r"\b(?:shooting|camera|capture|capturing|vantage|taking) (?:position|point|location|spot|place)\b|"
    r"\bposition(?:al)? (?:of|relationship)\b|\b(?:location|placement|whereabouts) of\b|"
    # "taken from which position?", "what spot was it shot from?"
    r"\b(?:which|what) (?:position|location|place|spot|vantage point|viewpoint|standpoint)\b|"
    r"\brelative (?:position|location|placement)\b|"
    rf"{_WHERE} (?:is|was|are|were) (?:the )?{_NOUNS} \w+\b|"
    r"\bwhich side of\b|\bin which direction (?:is|was|lies|lay)\b|"
    r"\b(?:which|what) (?:direction|side|way) (?:is|was|are|were|lies|lay) (?:the )?"
    rf"(?:camera|viewpoint|\w+ s camera|{_NOUNS} \w+ s camera|{_NOUNS} \w+ s viewpoint)\b"
)
# "What was the camera's motion?", "what is true of its movement?": a "what is" about the camera or
# its motion asks no object.
_ABOUT_CAMERA = (
    r"(?!\s+(?:the\s+)?(?:camera|photographer|shooter|viewer|lens|viewpoint|vantage)\b)"
    r"(?!\s+(?:the\s+|a\s+|its\s+)?(?:camera s\s+|photographer s\s+)?(?:overall\s+|net\s+)?"
    r"(?:motion|movement|displacement|rotation|translation|turn|change|shift|heading|orientation|pose|relation|relationship)\b)"
    r"(?!\s+(?:the\s+)?direction of (?:the\s+)?(?:camera|motion|movement|travel|displacement|view)\b)"
    r"(?!\s+(?:true|correct|right|different|accurate)\b)"
    # "what is the direction from image 1's camera to image 2's?", "the location of photo 2's camera"
    r"(?!\s+(?:the\s+)?(?:direction|position|location|placement|place|spot|whereabouts)\s+(?:of|from)\s+"
    r"(?:the\s+)?(?:(?:(?:image|photo|picture|view|shot|frame|snapshot)\s+\d+|(?:first|second|third|fourth|"
    r"fifth|last|final|other|earlier|later|initial)(?:\s+(?:image|photo|picture|view|shot|frame|snapshot|"
    r"one))?)\s+s\s+)?(?:camera|viewpoint|vantage point|shooting (?:position|point|location|spot))\b)"
)
_OBJECT_ASK = re.compile(
    rf"\b(?:what|which (?:object|item|thing))\s+(?:is|was|would be|will be|lies|appears)\b{_ABOUT_CAMERA}|"
    r"\bwhere (?:is|was|are) (?:the|a|an) (?!camera|photographer|shooter|viewer|second|first|third|"
    r"fourth|fifth|"
    r"last|final|initial|latter|former|next|previous|other|earlier|later|\d|"
    r"shooting|position|viewpoint|vantage|location|spot|place|capture|image|photo|picture|view|frame|shot|"
    r"snapshot)\w+"
)
_ROTATION_WORDS = re.compile(
    r"\b(?:point\w*|fac(?:e|ed|es|ing)|look\w*|aim\w*|turn\w*|rotat\w*|tilt\w*|roll\w*|pan\w*)\b"
)
# A note on conventions ("Clockwise is as seen looking along the lens.") is not what is asked.
_PARENTHESES = re.compile(r"\([^)]*\)")


def _without_notes(text: str) -> str:
    """The text without its parenthesised notes ("(clockwise as seen from behind)"); a parenthesis
    that names a photo and is no note on directions stays ("image 3 (taken after image 1)",
    "photo (2)")."""

    def keep(match: re.Match[str]) -> str:
        inner = match.group()[1:-1]
        names = bool(read_pair(inner).view_set) or bool(re.fullmatch(r"\s*#?\s*\d+\s*", inner))
        return f" {inner} " if names and not _FRAME_NOTE.search(inner) else " "

    return _PARENTHESES.sub(keep, text)


_SENTENCE = re.compile(r"(?<=[.!?;:])\s+(?=[A-Z])")
# A note on whose directions are meant ("Directions are as the photographer saw them when taking the
# last picture."): it names a view for the frame, not for the pair.
_FRAME_NOTE = re.compile(
    r"\b(?:directions?|axes|left and right|up and down|as (?:the photographer|the camera|seen)|"
    r"frame of reference|reference frame|coordinates?|sense of rotation|clockwise|counterclockwise|"
    r"counter-clockwise|anticlockwise|judged|counted)\b",
    re.IGNORECASE,
)


def _pair(ask: str, image_count: int | None, camera: bool) -> PairReading:
    """The pair from the asking sentences when their words order it; else from the whole question
    (notes on the frame left out) when its words order it: "First came shot 2; shot 4 followed.
    Where did the camera go?", "Take image 2 as the origin. Where was image 1 taken?"; else what the
    asking sentences give (the order of mention, the other of two photos, a doubt)."""
    asking = read_pair(asking_sentences(ask), image_count, default_two=False)
    if asking.by_words:
        return asking
    sentences = [s for s in _SENTENCE.split(_without_notes(ask)) if s.strip()]
    setup = " ".join(s for s in sentences if "?" in s or not _FRAME_NOTE.search(s))
    whole = read_pair(setup, image_count, default_two=camera)
    if whole.by_words or (asking.views is None and asking.doubt is None):
        return whole
    return asking


def asking_sentences(ask: str) -> str:
    """The sentences that ask (those with a question mark; else the last one), notes left out."""
    sentences = [s for s in _SENTENCE.split(_without_notes(ask)) if s.strip()]
    asking = [s for s in sentences if "?" in s]
    return " ".join(asking or sentences[-1:])


_ROTATING = ("aim", "aimnoun", "yaw", "pitch", "roll")
# Where the camera went ("where did it end up?"): the step, not the place of one camera seen from the
# other (the same geometry, asked as a motion).
_DESTINATION = re.compile(
    r"\bwhere (?:did|does|has|had|would|do) (?:the camera|it|the photographer|the shooter|the viewer|they|"
    r"you|we|i|the lens) (?:end up|ended up|wind up|wound up|finish|land|arrive|get|got|go|gone|move|"
    r"moved|travel|head|shift|walk|drift|relocate|come to rest|wander|proceed|get to|go to)\b"
)
# Nouns of the direction a camera looks ("the viewing direction", "the line of sight"): a change of
# one is a rotation, whatever verb asks about it ("what change of viewing direction occurred?").
_LOOK_NOUNS = re.compile(
    r"\b(?:(?:viewing|view|looking|facing|pointing|sight|gaze|shooting|lens|optical|camera s|camera)\s+"
    r"(?:direction|angle|axis|orientation|heading|bearing)|line of sight|direction of (?:view|gaze|sight)|"
    r"orientation|heading|bearing|attitude|(?:re)?orient(?:ed|ing|s)?)\b"
)
# The verbs that build the pair, not the quantity: "what did it do going from image 1 to image 2?",
# "on the way to"; not the main verb ("where was the camera going from image 1 to image 2?").
_PAIR_VERBS = re.compile(
    r"(?<!\bcamera )(?<!\bit )(?<!\bthey )(?<!\byou )(?<!\bwe )(?<!\bi )(?<!\bphotographer )(?<!\bshooter )"
    r"\b(?:going|coming|on (?:the|its) way)(?= (?:back )?(?:from|to) )"
)
# A step verb set beside a turn ("did it move or turn?", "moving and rotating"): both are asked.
_MOVE_OR_TURN = re.compile(
    r"\b(?:mov(?:e|ed|es|ing)|go|went|shift(?:ed|s|ing)?) (?:or|and|and or|and/or) "
    r"((?:turn|rotat|pan|tilt|roll|pivot|swivel)\w*)\b"
)
_AUX_POINT = re.compile(r"\b((?:did|does|do|can|would|will) (?:the|its) cameras?) point\b")
_GET_TAKEN = re.compile(r"\b(?:get|got|gets|getting|gotten) (taken|shot|captured|photographed|snapped)\b")
_PLACE_POINT = re.compile(r"\b(?:capture|capturing|shooting|vantage|taking|camera|view|standing) point\b")
# A look that shifts is a turn: "how did the camera's aim shift?" ("shift" alone is a step).
_LOOK_SHIFTS = re.compile(
    r"\b(?:aim|heading|orientation|gaze|line of sight|(?:viewing|view|looking|facing|pointing|lens) "
    r"(?:direction|angle|axis))\s+(?:(?!and\b|or\b|position\b|location\b|place\b)\w+\s+){0,2}(?:shift\w*|mov\w*|drift\w*|sw[iu]ng\w*|chang\w*|go|went|gone|"
    r"slid\w*|travel\w*)\b"
)
# The place of one camera, said with a verb of lying or standing: "where does image 2's camera lie
# relative to image 1's?", "how is its viewpoint placed?"
_CAMERA_PLACED = re.compile(
    r"\b(?:camera|viewpoint|vantage point|shooting (?:position|point|spot))\b[^?]*?\b(?:lie|lies|lay|lying|"
    r"located|situated|placed|positioned|sit|sits|sat|sitting|stand|stands|stood|standing|found)\b"
    r"(?!\s+still\b)"
)
_PLACE_NOUN = re.compile(
    r"\b(?:location|position|placement|positioning|spot|"
    r"(?<!\btook )(?<!\btake )(?<!\btakes )(?<!\btaking )place|"
    r"whereabouts|standpoint)\b"
)


def _stem_quantity(ask: str) -> tuple[Quantity | None, bool, str]:
    """(quantity, strong, the words): strong when a word of one kind says it ("tilt"), weak for
    the everyday verbs ("move"), None when nothing does."""
    if (only := _only_about(ask)) is not None:
        return only
    plain = normalized(_APART_FROM.sub(" ", ask))
    look_shifts = bool(_LOOK_SHIFTS.search(plain))
    words = _LOOK_SHIFTS.sub(" turned ", plain)  # "its aim shifted"
    words = _PAIR_VERBS.sub(" ", words)  # "going from image 1 to image 2" asks no step
    words = _MOVE_OR_TURN.sub(r"translated \1", words)  # "move or turn": a step is asked as well
    words = _AUX_POINT.sub(r"\1 aim", words)  # "where did the camera point?" is a look, not a place
    words = _GET_TAKEN.sub(r"was \1", words)  # "where did image 2 get taken?": a passive, no step
    words = _PLACE_POINT.sub(" spot", words)  # "its capture point" is a place, not a way it points
    words = re.sub(r"\bpoints? of view\b", "viewpoint", words)  # a place and a look: no turn alone
    # "Not counting rotation, where did it go?": what is set aside is not asked, so the rest is
    set_aside = [m.group("what") or m.group("before") or m.group("out") for m in _APART_FROM.finditer(ask)]
    excluded = {s.kind for what in set_aside for s in stem_senses(what)}
    if any(_LOOK_NOUNS.search(normalized(what)) for what in set_aside):
        excluded.add("aim")  # "leaving aside the change in viewing direction"
    kinds = [s.kind for s in stem_senses(words)]
    if not any(k in _ROTATING for k in kinds) and excluded & set(_ROTATING):
        return "translation", True, words
    if not any(k in ("step", "weak") for k in kinds) and excluded & {"step", "weak", "place", "placenoun"}:
        return "rotation", True, words
    stepping = any(s.kind in ("step", "weak") for s in stem_senses(words))  # "shift", "go", "change"
    looking = (look_shifts or bool(_LOOK_NOUNS.search(words))) and not any(k == "step" for k in kinds)
    if looking and _PLACE_NOUN.search(words):
        return "motion", True, words  # "how did its viewing direction and position change?"
    if _DESTINATION.search(words) and not looking and not any(k in _ROTATING for k in kinds):
        return "translation", True, words
    position = _POSITION_ASK.search(words) or _CAMERA_PLACED.search(words)
    if position and not _ROTATION_WORDS.search(words) and not stepping and not looking:
        return "position", True, position.group()
    if stepping and _PLACE_NOUN.search(words) and not any(k in _ROTATING for k in kinds):
        return "translation", True, words  # "the camera's location changed": a step, however said
    rotation = any(k in _ROTATING for k in kinds) or looking
    translation = any(k == "step" for k in kinds)
    if rotation and translation:
        return "motion", True, words
    if rotation:
        return "rotation", True, words
    if translation:
        return "translation", True, words
    senses = stem_senses(words)
    if any(s.kind == "weak" and s.value is None for s in senses) or "still" in kinds:
        return "translation", False, words  # "which way did it move? Left": a step
    if "weak" in kinds or _DID_WHAT.search(words):
        return "motion", False, words  # "how did it change?", "what did the camera do?": any motion
    return None, False, ""


# "Only considering where it stood, ...", "looking only at orientation, ...", "in terms of position
# only": what the question restricts itself to is the quantity it asks.
_ONLY_ABOUT = re.compile(
    r"\b(?:(?:only|just|purely|solely|strictly) (?:considering|looking at|in terms of|regarding|counting|"
    r"as to|as regards)|(?:considering|looking at|in terms of|regarding|as regards|taking|counting) "
    r"(?:only|just|purely|solely)|looking (?:only|just|purely|solely) at)\s+(?P<what>[^,?;.:]+)|"
    r"\b(?:in terms of|considering|looking at|regarding|as regards) (?P<alone>[^,?;.:]+?) (?:only|alone)\b",
    re.IGNORECASE,
)


def _only_about(ask: str) -> tuple[Quantity, bool, str] | None:
    """The quantity a restriction names ("only considering where it stood": a step), when it names one
    kind, and the rest does not ask where one camera is; else None."""
    named = [m.group("what") or m.group("alone") for m in _ONLY_ABOUT.finditer(ask)]
    if not named:
        return None
    rest = normalized(_ONLY_ABOUT.sub(" ", ask))
    if _POSITION_ASK.search(rest) or _CAMERA_PLACED.search(rest):
        return None
    words = normalized(" ".join(named))
    kinds = {s.kind for s in stem_senses(words)}
    turning = bool(kinds & set(_ROTATING)) or bool(_LOOK_NOUNS.search(words))
    where = re.search(r"\bwhere\b", words) is not None  # "only considering where it stood"
    placing = bool(kinds & {"step", "place", "placenoun"}) or where or bool(_PLACE_NOUN.search(words))
    if turning != placing:
        return ("rotation" if turning else "translation"), True, words
    return None


# "What did the camera do?", "the camera did what?": any motion.
_DID_WHAT = re.compile(
    r"\b(?:what did|what has|what had) (?:the )?(?:camera|photographer|shooter|viewer|observer|it|you|we|i) "
    r"(?:do|done)\b|\b(?:camera|photographer|shooter|viewer|observer) (?:did|does) what\b"
)


def _option_kinds(options: dict[str, Claim]) -> set[str]:
    kinds: set[str] = set()
    for claim in options.values():
        kinds |= claim_kinds(claim)
    return kinds


def _compatible(stem: Quantity, options: set[str]) -> bool:
    moving = options - {"still"}
    if not moving or stem == "motion":
        return True
    if stem == "rotation":
        return moving == {"rotation"}
    return moving <= {"translation", "position"}  # a step and a place are the same geometry


def _quantity(
    ask: str, options: dict[str, Claim], named: dict[str, frozenset[str]] | None = None
) -> tuple[Quantity, bool, str, str | None]:
    """(quantity, certain, source, why it must abstain). `named`: for unread options, the kinds
    their verbs name (`kinds_named`): with the read options' kinds, what the options are known to
    ask, when the stem does not say it with a word of one kind."""
    stem, strong, stem_words = _stem_quantity(asking_sentences(ask))
    kinds = _option_kinds(options)
    lead = bool(options) and all(is_read(c) for c in options.values())
    moving = kinds - {"still"}
    if lead and moving:
        of_options: Quantity = moving.pop() if len(moving) == 1 else "motion"  # type: ignore[assignment]
        if stem is not None and strong and not _compatible(stem, kinds):
            return (
                of_options,
                False,
                "the options",
                f"the stem asks about {stem} but the options state {of_options}",
            )
        if stem == "position" and of_options == "translation":
            return "position", True, "the stem and the options", None
        return of_options, True, "the options", None
    if stem is not None and moving and strong and not _compatible(stem, kinds):
        return (
            stem,
            False,
            stem_words,
            f"the stem asks about {stem} but some options state {', '.join(sorted(moving))}",
        )
    # Options partly read: the kinds the read ones state, and those the unread ones' verbs name
    # ("It rolled toward the clock's hands": a turn, its sense not read), are the quantity when the
    # stem says none with a word of one kind; never certain while an option's kind is only named.
    hinted = set().union(*(named or {}).values()) - kinds
    known = (kinds | hinted) - {"still"}
    if known and _bare_steps(options, known):
        # a bare direction ("Higher", "Further back") is how people say a step, not a turn: beside
        # turns, the options then ask about any motion
        hinted.add("translation")
        known.add("translation")
    if known and not (stem is not None and strong):
        certain = not hinted and not _has_bare(options) and not _unread(options)
        return _of_kinds(known, stem), certain, "the options", None
    if stem is not None:
        return stem, strong or not _has_bare(options), stem_words, None
    if kinds == {"still"}:
        return "still", True, "the options", None
    return "other", False, "", None


def _of_kinds(kinds: set[str], stem: Quantity | None) -> Quantity:
    """The quantity several options' kinds ask: a step and a place are one geometry (a place when
    the stem asks where a camera is), a step and a turn are any motion."""
    if kinds <= {"translation", "position"}:
        place = "position" in kinds and (len(kinds) == 1 or stem == "position")
        return "position" if place else "translation"
    return "rotation" if kinds == {"rotation"} else "motion"


def _bare_steps(options: dict[str, Claim], known: set[str]) -> bool:
    """Whether a bare direction stands beside turns, with no step read among the options."""
    bare = [c for c in options.values() if isinstance(c, Bare)]
    return bool(bare) and "rotation" in known and not known & {"translation", "position"}


def _unread(options: dict[str, Claim]) -> bool:
    return any(isinstance(c, Unread) for c in options.values())


def _has_bare(options: dict[str, Claim]) -> bool:
    return any(isinstance(c, Bare) for c in options.values())


# ---- the frame ------------------------------------------------------------------------------

_ROOM = re.compile(
    r"\b(?:in the (?:room|world|real world|scene)|relative to (?:the )?(?:ground|floor|gravity|room|world)|"
    r"gravity|vertically in the room|above the floor|toward the ceiling)\b"
)
_VIEW_AXES = re.compile(
    r"\b(?:in|from|using|relative to|with respect to|according to|as seen (?:in|from))\s+(?:the\s+)?"
    r"(?P<view>[\w ]{1,25}?)\s*(?:s\s+)?(?:own\s+)?(?:axes|directions|coordinates|"
    r"coordinate (?:frame|system)|"
    r"frame of reference|reference frame|orientation|point of view|viewpoint|perspective|side)\b"
)
# The same with the view after its noun: "in the directions of image 2", "along the axes of the second
# photo". A few words after "of" are read as a pair; only the view they name is kept.
_VIEW_AXES_OF = re.compile(
    r"\b(?:in|from|use|using|relative to|with respect to|according to|along|as seen (?:in|from))\s+"
    r"(?:the\s+)?(?:own\s+)?(?:axes|directions|coordinates|coordinate (?:frame|system)|frame of reference|"
    r"reference frame|orientation|point of view|viewpoint|perspective)\s+of\s+(?:the\s+)?"
    r"(?P<view>\w+(?:\s+\w+){0,2})"
)
# Words that say whose axes are meant ("use image 2's axes itself"); when none of the patterns above
# read them, the frame is unread (not the default).
_FRAME_WORDS = re.compile(
    r"\b(?:axes|coordinates|coordinate (?:frame|system)|frame of reference|reference frame|"
    r"directions of|s (?:own )?directions)\b"
)
_SHOOTER = re.compile(r"\b(?:shooter|photographer|camera operator|camera person|viewer|camera)\b")
# "the camera that took image 2", "the photographer of the second photo": the shooter of one photo
_TOOK = re.compile(
    r"(?:the )?(?:shooter|photographer|camera operator|camera person|viewer|camera)\s+"
    r"(?:(?:that|which|who)\s+)?(?:took|taking|shot|captured|photographed|of|for|behind)\s+(?P<photo>(?:the\s+)?\w+(?:\s+\w+)?)"
)


def _photo_taken(words: str, start: int, image_count: int | None) -> tuple[int, str] | None:
    """(the photo, the words) when the shooter named at `start` is said to be that of one photo."""
    took = _TOOK.match(words, start)
    named = views_mentioned(took.group("photo"), image_count) if took else ()
    return (named[0], took.group()) if took and len(named) == 1 else None


_OBJECT_FRAME = re.compile(
    r"\b(?:facing|from|at) the (?P<object>(?!camera|photographer|shooter|"
    r"viewer)\w+)\s+(?:s\s+)?(?:perspective|point of view|position)\b"
)


def _frame(
    ask: str, views: tuple[int, int] | None, image_count: int | None
) -> tuple[FrameReading | None, str, bool]:
    words = normalized(ask)
    if room := _ROOM.search(words):
        return FrameReading(kind="room"), room.group(), True
    if of := _VIEW_AXES_OF.search(words):
        named = read_pair(of.group("view"), image_count).view_set
        if named:
            return FrameReading(kind="view_axes", view=named[0]), of.group(), True
        if _SHOOTER.search(of.group("view")) and (took := _photo_taken(words, of.start("view"), image_count)):
            return FrameReading(kind="view_axes", view=took[0]), took[1], True
        if _SHOOTER.search(of.group("view")) and views is not None:
            return FrameReading(kind="view_axes", view=views[0]), of.group(), True
        return FrameReading(kind="object", object=of.group("view").split()[0]), of.group(), True
    if axes := _VIEW_AXES.search(words):
        named = read_pair(axes.group("view"), image_count).view_set
        if len(named) == 1:  # "from image 1 to image 2 in the coordinates ..." names no one view
            return FrameReading(kind="view_axes", view=named[0]), axes.group(), True
        if _SHOOTER.search(axes.group("view")) and views is not None:
            return FrameReading(kind="view_axes", view=views[0]), axes.group(), True
    if obj := _OBJECT_FRAME.search(words):
        return FrameReading(kind="object", object=obj.group("object")), obj.group(), True
    note_view, note = _axes_note(ask, image_count)
    if note_view is not None:
        return FrameReading(kind="view_axes", view=note_view), note, True
    if views is None:
        return None, "", False
    # The first photo's, unless said; words that name axes but were not read above keep it uncertain
    # with their source, so that the answer is refused rather than given in a frame not asked.
    unread = _FRAME_WORDS.search(words)
    return FrameReading(kind="view_axes", view=views[0]), note or (unread.group() if unread else ""), False


# A note on whose directions are meant, said as a sentence of its own ("Directions are relative to
# image 1's camera.", "Left and right are as the photographer of photo 2 saw them."): the one photo it
# names is the one whose axes are meant. A note that names several photos, or says whose axes are not
# meant ("not those of image 2"), is not read: the frame is then left unread, and the answer refused.
_AXES_NOTE = re.compile(
    r"\b(?:directions?|axes|left and right|up and down|left right up and down|coordinates?|"
    r"coordinate (?:frame|system)|frame of reference|reference frame|orientation as (?:the )?reference|"
    r"point of view|perspective)\b"
)
_NOT_THESE = re.compile(r"\b(?:not|never|instead of|rather than|unlike|except|other than|but not)\b")


def _axes_note(ask: str, image_count: int | None) -> tuple[int | None, str]:
    """(the photo a note on directions names, the note) for the first such note; (None, note) when
    it is not read; (None, "") when there is none. Questions are not notes (their words are read
    above)."""
    notes = [s for s in _SENTENCE.split(ask) if "?" not in s] + [
        m.group()[1:-1] for m in _PARENTHESES.finditer(ask)
    ]
    for note in notes:
        words = normalized(note)
        if not _AXES_NOTE.search(words):
            continue
        named = views_mentioned(note, image_count)
        if not named:
            continue  # "Clockwise is as seen from behind the camera": a sense, no photo
        if len(named) == 1 and not _NOT_THESE.search(words):
            return named[0], words
        return None, words
    return None, ""


# ---- the whole reading ----------------------------------------------------------------------

_QUANTITY_WORDS = {
    "translation": "camera translation",
    "rotation": "camera rotation",
    "position": "position of the second camera relative to the first",
    "motion": "camera motion",
    "still": "whether the camera stayed still",
    "object_relation": "an object relation",
    "other": "no camera quantity",
}


def _summary(quantity: Quantity, pair: PairReading, frame: FrameReading | None) -> str:
    said = f"read as: {_QUANTITY_WORDS[quantity]}"
    if quantity not in CAMERA_QUANTITIES:
        return said
    if pair.views is not None:
        said += f" from image {pair.views[0]} to image {pair.views[1]}"
    if frame is not None and frame.kind == "view_axes" and frame.view is not None:
        said += f", in image {frame.view}'s axes"
    elif frame is not None and frame.kind == "room":
        said += ", in the room's axes"
    elif frame is not None and frame.kind == "object":
        said += f", from the {frame.object}"
    return said


# An option that offers alternatives ("it rose, or it moved ahead") says two things, however its
# parts are worded: even when the words of one part are not read, it is no single claim.
_ALTERNATIVES = re.compile(r"\bor\b")


def _abstain(
    quantity: Quantity, pair: PairReading, options: dict[str, Claim], quantity_doubt: str | None
) -> str | None:
    """Why a camera reading must not be answered from, whatever the measurement (None: it may)."""
    if quantity not in CAMERA_QUANTITIES:
        return None
    if pair.doubt is not None:
        return pair.doubt
    if pair.views is None:
        return "the question does not say which two photos it compares"
    if quantity_doubt is not None:
        return quantity_doubt
    double = [
        letter
        for letter, claim in options.items()
        if (isinstance(claim, Unread) and claim.two_claims) or _ALTERNATIVES.search(normalized(claim.source))
    ]
    if double:
        return f"option {', '.join(double)} reads as two claims"
    bare = [letter for letter, claim in options.items() if isinstance(claim, Bare)]
    if bare:
        return (
            f"option {', '.join(bare)} reads two ways (a step or a turn): the question does not say "
            "which motion it asks about"
        )
    return None


def _bare_sense(quantity: Quantity, ask: str, options: dict[str, Claim]) -> Quantity:
    """What a bare direction means: the quantity the stem asks when a word of one kind says it
    ("which way did it pan? Left" is a yaw); with an everyday verb ("how did it move? Forward") a
    step, unless another option is a turn. The other options alone never give a bare one its kind
    ("It ended up further left" beside turns may be a step): it stays bare, and the reading abstains."""
    stem, strong, _ = _stem_quantity(asking_sentences(ask))
    if stem in ("translation", "rotation", "position") and strong:
        return stem
    turns = any("rotation" in claim_kinds(claim) for claim in options.values())
    if stem == "translation" and not turns and quantity in ("translation", "position", "still"):
        return quantity if quantity != "still" else "translation"
    if quantity == "position" and stem is None and not turns:
        return quantity
    return "motion"


def _with_bare_resolved(options: dict[str, Claim], quantity: Quantity) -> dict[str, Claim]:
    return {
        letter: resolve_bare(_only_a_step(claim, quantity), quantity) for letter, claim in options.items()
    }


def _only_a_step(claim: Claim, quantity: Quantity) -> Claim:
    """ "Ahead" / "Toward the scene" can only be a step (no turn goes forward): a step, or the
    position in a position question, whatever else the stem leaves open."""
    if isinstance(claim, Bare) and set(claim.ways) == {"forward"} and quantity != "rotation":
        # (in a question about turning, "Forward" may mean it kept facing ahead: left bare)
        return resolve_bare(claim, "position" if quantity == "position" else "translation")
    return claim


def read_question(text: str, image_count: int | None = None) -> QuestionReading:
    """The question's one reading (see the module docstring); views are 1-based."""
    stem, option_texts = split_options((text or "").strip())
    ask = _ask(" ".join(stem.split()))
    options = {letter: read_phrase(words) for letter, words in option_texts.items()}
    named = {
        letter: kinds_named(option_texts[letter]) for letter, c in options.items() if isinstance(c, Unread)
    }
    quantity, certain, source, doubt = _quantity(ask, options, named)
    hypothetical = bool(_WHAT_IF.search(normalized(asking_sentences(ask))))
    if quantity not in CAMERA_QUANTITIES or hypothetical or (not _lead(options) and not _is_camera_ask(ask)):
        quantity = "object_relation" if _OBJECT_ASK.search(normalized(ask)) else "other"
    options = _with_bare_resolved(options, _bare_sense(quantity, ask, options))
    pair = _pair(ask, image_count, camera=quantity in CAMERA_QUANTITIES)
    options = _views_checked(options, option_texts, pair.views)
    frame, frame_source, frame_certain = _frame(ask, pair.views, image_count)
    return QuestionReading(
        text=(text or "").strip(),
        image_count=image_count,
        views=pair.views,
        view_set=pair.view_set,
        views_source=pair.source,
        views_certain=pair.certain,
        quantity=quantity,
        quantity_source=source,
        quantity_certain=certain and quantity in CAMERA_QUANTITIES,
        frame=frame,
        frame_source=frame_source,
        frame_certain=frame_certain,
        options=options,
        abstain_reason=_abstain(quantity, pair, options, doubt),
        summary=_summary(quantity, pair, frame),
    )


def _views_checked(
    options: dict[str, Claim], texts: dict[str, str], views: tuple[int, int] | None
) -> dict[str, Claim]:
    """An option that names photos by number ("Image 1 was taken to the left of image 2") states
    its claim about those photos: kept when they are the pair's (the second about the first),
    unread when they are the other way round (its claim is the pair's reversed) or not the pair."""
    checked = dict(options)
    for letter, claim in options.items():
        about, relative_to = views_named(texts.get(letter, ""))
        if (about is None and relative_to is None) or not is_read(claim):
            continue
        if views is None or about not in (None, views[1]) or relative_to not in (None, views[0]):
            checked[letter] = Unread(
                source=claim.source, why="it names the photos in another order or other photos than the pair"
            )
    return checked


def _lead(options: dict[str, Claim]) -> bool:
    return bool(options) and all(is_read(c) for c in options.values())


_CAMERA_ASK = re.compile(
    r"\b(?:camera|photographer|shooter|shooting|viewer|cameraman|lens|viewpoint|vantage|"
    r"(?:did|do|have|had) (?:i|you|we)|(?:i|you|we) "
    r"(?:moved|turned|went|walked|rotated|tilted)|shot|photo|photos|image|images|picture|pictures|frame|view|"
    r"views|snapshot|taken)\b"
)


# A move not yet made ("if you turn left", "imagine walking", "will you be closer"): a what-if about
# the scene, not the motion between two photos.
_WHAT_IF = re.compile(
    r"\b(?:if (?:you|i|we|the camera)\b|suppose|supposing|imagine|were to|"
    r"will (?:you|i|we) (?:be|get|see|end)|"
    r"would (?:you|i|we)(?! (?:find|locate|place|put|say|describe|call|expect to find)\b)|"
    r"after (?:you|i|we) (?:turn|walk|move|step|rotate)|(?:^|"
    r", )(?:then )?(?:turn|walk|move) )"
)


# "What is the relative position of the camera in image 1 ...?": a "what is" about a camera.
_CAMERA_POSITION = re.compile(r"\b(?:position|location|placement)\b[^?]*\b(?:camera|photographer|shooter)\b")


def _is_camera_ask(ask: str) -> bool:
    """A stem about the camera (or the photos it took), not about objects in them nor a what-if."""
    asking = normalized(asking_sentences(ask))
    about_objects = bool(_OBJECT_ASK.search(asking)) and not _CAMERA_POSITION.search(asking)
    return bool(_CAMERA_ASK.search(normalized(ask))) and not about_objects and not _WHAT_IF.search(asking)


def _ask(stem: str) -> str:
    """The asking part of a stem: an opening that lists every view ("Based on these four images
    (image 1, 2, 3, and 4) ...:") names no view in particular."""
    opening = re.match(
        r"^[^:?]*\((?:image|view|photo)s?\s*\d+(?:\s*(?:,|and|, and)\s*\d+)+\)[^:?]*:\s*", stem, re.I
    )
    return stem[opening.end() :] if opening else stem


__all__ = [
    "CAMERA_QUANTITIES",
    "FrameReading",
    "Quantity",
    "QuestionReading",
    "asking_sentences",
    "read_question",
]
