"""Read a MindCube-style question once into a typed intent: what it asks, from which view, after what.

Real MindCube questions open by naming every view ("Based on these four images (image 1, 2, 3, and
4) showing the orange ball from different viewpoints (front, left, back, and right), ...:"), may
state how the views relate ("The image 2 was taken after turning the camera 90 degrees to the right
(clockwise) from where image 1 was taken."), and only then ask ("From the viewpoint presented in
image 2, what is to the right of the orange ball?"). So the question is split into its opening,
its setup sentences and its ask, and views are read from the ask only: the first view mentioned
anywhere is almost always the opening's "image 1".

Families (MindCube's question kinds):

- ``self_movement``: how the camera / I moved or turned from image i to image j (a view pair).
- ``relative_direction``: what is to the left / right / behind / in front of me, or of a named
  object, seen from view k (rotation-setting questions are these, not camera motion).
- ``what_if``: after turning and/or moving (in order) from view k, what is in some direction, or
  am I closer to / farther from an object.
- ``occlusion``: what hides what, or what is visible from a view.
- ``object_perspective``: standing at a named object's position, facing something: what is where.
- ``unknown``: none of these.

The planner, the answerers and the prompts take this structure instead of re-reading the text.
"""

from __future__ import annotations

import re
from typing import Literal

from pydantic import BaseModel, Field

from shared.questions.choices import split_options
from shared.questions.motion_words import AskedMotion, Frame, asked_frame, asked_motion
from shared.questions.reading import QuestionReading, read_question

Setting = Literal["among", "around", "rotation", "translation", "unknown"]
Family = Literal[
    "self_movement", "relative_direction", "what_if", "occlusion", "object_perspective", "unknown"
]
Direction = Literal[
    "front", "behind", "left", "right", "front-left", "front-right", "back-left", "back-right"
]
Comparison = Literal["distance"]


class PoseStep(BaseModel, frozen=True):
    """One turn or move, in the order the question makes them."""

    kind: Literal["turn", "move"]
    side: Literal["left", "right", "around", "forward", "backward"]
    degrees: float | None = None  # turns: stated angle (90 when unstated; 180 for "around")
    meters: float | None = None  # moves: stated distance, None for the tool's default

    @property
    def words(self) -> str:
        if self.kind == "turn":
            return "turn around" if self.side == "around" else f"turn {self.side} {self.degrees:g} degrees"
        return f"move {self.side}" + (f" {self.meters:g} m" if self.meters is not None else "")


class ViewRelation(BaseModel, frozen=True):
    """A setup sentence: view ``later`` was taken after turning ``degrees`` to ``side`` from ``earlier``."""

    earlier: int
    later: int
    side: Literal["left", "right"]
    degrees: float


class QuestionIntent(BaseModel):
    text: str = Field(
        "",
        exclude=True,  # not sent back: the client has the question it asked
        description="The question as asked (stripped), for the prompts that quote it.",
    )
    setting: Setting
    family: Family
    ask: str = Field(description="The asking part of the question (opening and setup removed).")
    asked_view: int | None = Field(None, description="1-based view the question is asked from.")
    motion_pair: tuple[int, int] | None = Field(None, description="Views of a self-movement question.")
    asks_turn_only: bool = False  # "how did I turn?": the answer is a turn, not a walk
    motion_asked: AskedMotion = Field(
        "any",
        description="Self-movement: what bare option words name (tilt: 'Up' is a tilt), see motion_words.",
    )
    motion_frame: Frame = Field(
        "image",
        description="Self-movement: the photos' own axes, or the room's gravity frame when it says so.",
    )
    steps: list[PoseStep] = Field(default_factory=list)
    direction: Direction | None = Field(None, description="The final direction asked about.")
    target_object: str | None = Field(None, description="The object named: 'the orange ball'.")
    comparison: Comparison | None = None  # what_if: closer / farther
    relations: list[ViewRelation] = Field(default_factory=list)
    mentioned_views: list[int] = Field(default_factory=list, description="Every view the ask names.")
    options: dict[str, str] = Field(default_factory=dict)
    offline_reason: str | None = Field(
        None, description="Why the offline planner cannot write a program for this family (None: it can)."
    )
    reading: QuestionReading | None = Field(
        None,
        exclude=True,  # the response carries it once, as its own `reading` field
        description="The typed reading of a camera question (shared/questions/reading.py).",
    )

    @property
    def view(self) -> int:
        """The view to stand at: the asked view, else the pair's first, else image 1."""
        if self.asked_view is not None:
            return self.asked_view
        if self.motion_pair is not None:
            return self.motion_pair[0]
        return 1


# ---- views -------------------------------------------------------------------------------------

_NOUN = r"(?:images?|views?|pictures?|photos?|photographs?|frames?|shots?|snapshots?|viewpoints?)"
_ORDINALS = {
    "first": 1, "second": 2, "third": 3, "fourth": 4, "fifth": 5,
    "sixth": 6, "seventh": 7, "eighth": 8, "ninth": 9, "tenth": 10,
}  # fmt: skip
_ORDINAL = r"(first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|last|final|\d+(?:st|nd|rd|th))"
_NUMBERED = re.compile(
    rf"\b{_NOUN}\s*(?:#|no\.?\s*|number\s+)?(\d+)((?:\s*(?:,|and|to|&|->|→|-)\s*\d+\b)*)", re.IGNORECASE
)
_ORDINAL_REF = re.compile(rf"\b{_ORDINAL}\s+(?:[a-z]+\s+)?{_NOUN}\b", re.IGNORECASE)


def _ordinal_value(word: str, num_images: int) -> int:
    word = word.lower()
    if word in ("last", "final"):
        return num_images
    if word in _ORDINALS:
        return _ORDINALS[word]
    return int(re.match(r"\d+", word).group())


def _view_mentions(text: str, num_images: int) -> list[tuple[int, int]]:
    """(position, view) of every view the text names, in order."""
    found: list[tuple[int, int]] = []
    for match in _NUMBERED.finditer(text):
        found.append((match.start(1), int(match.group(1))))
        for extra in re.finditer(r"\d+", match.group(2) or ""):
            found.append((match.start(2) + extra.start(), int(extra.group())))
    for match in _ORDINAL_REF.finditer(text):
        found.append((match.start(), _ordinal_value(match.group(1), num_images)))
    return sorted(found)


def view_references(text: str, num_images: int) -> list[int]:
    """The views a text names, 1-based, in order of mention ("views 1 and 3" gives [1, 3])."""
    return [view for _, view in _view_mentions(text, num_images)]


# "From the viewpoint presented in image 2", "standing where image 3 was taken", "in photo 1".
_ASKED_FROM = re.compile(
    rf"\b(?:from|at|in|where|of|for)\s+(?:the\s+)?(?:(?:viewpoint|perspective|position|view|camera)\s+"
    rf"(?:presented|shown|captured|seen|of|in|from)?\s*(?:in|by|of)?\s*)?(?:the\s+)?(?={_NOUN}\s*\d|{_ORDINAL}\s+{_NOUN})",
    re.IGNORECASE,
)


# ---- the parts of a question ------------------------------------------------------------------

_OPENING = re.compile(rf"^(?P<opening>[^:?]*\b{_NOUN}\b[^:?]*):\s+(?P<rest>.+)$", re.DOTALL | re.IGNORECASE)
_SENTENCES = re.compile(r"(?<=[.!?])\s+(?=[A-Z(])")
# A setup sentence has views as its subject: "The image 2 was taken after turning the camera ...".
_SETUP = re.compile(
    rf"^(?:the\s+|these\s+|both\s+|all\s+)?(?:\w+\s+)?{_NOUN}\s*(?:\d+\s+)?(?:was|were|is|are)\s+(?:all\s+)?"
    r"(?:taken|captured|shot)\b",
    re.IGNORECASE,
)


# "(image 1, 2, 3, and 4)": a list of every view, wherever it stands, names no view in particular.
_VIEW_LIST = re.compile(rf"\(\s*{_NOUN}\s*\d+(?:\s*(?:,|and|,\s*and)\s*\d+)+\s*\)", re.IGNORECASE)


def _parts(stem: str) -> tuple[str, list[str], str]:
    """(opening, setup sentences, ask). The opening is the text before a colon that names views."""
    opening, rest = "", stem
    match = _OPENING.match(stem)
    if match:
        opening, rest = match.group("opening"), match.group("rest")
    rest = _VIEW_LIST.sub("", rest)
    sentences = [s.strip() for s in _SENTENCES.split(rest) if s.strip()]
    setup = [s for s in sentences if _SETUP.match(s) and "?" not in s]
    ask = " ".join(s for s in sentences if s not in setup) or rest
    return opening, setup, ask


# ---- setting -----------------------------------------------------------------------------------

_SETTING_PREFIXES: tuple[tuple[str, Setting], ...] = (
    ("aroundnew", "around"),
    ("around", "around"),
    ("among", "among"),
    ("rotation", "rotation"),
    ("translation", "translation"),
)


def setting_from_id(item_id: str | None) -> Setting | None:
    """MindCube's setting from an item id's prefix ("among_group238_q1_5_2" gives "among")."""
    lowered = (item_id or "").lower()
    for prefix, setting in _SETTING_PREFIXES:
        if lowered.startswith(prefix):
            return setting
    return None


def _setting_from_words(stem: str, relations: list[ViewRelation]) -> Setting:
    lowered = stem.lower()
    if relations or re.search(r"\bturning the camera\b|\bfrom the same (?:spot|position|place)\b", lowered):
        return "rotation"
    if re.search(r"\(front, left, back,? and right\)|aligned with (?:the )?room walls", lowered):
        return "among"
    if re.search(r"\bmov(?:ing|ed) around\b|\bwalk(?:ing|ed)? around\b|\bcircl", lowered):
        return "around"
    return "unknown"


# ---- what is asked -----------------------------------------------------------------------------

_DEGREES = r"(\d+(?:\.\d+)?)\s*(?:°|degrees?|deg\b)"
_SIDE = r"(left|right|around|clockwise|counter-?clockwise|anti-?clockwise)"
_TURN_STEP = re.compile(
    rf"\b(?:turn|turns|turned|turning|rotate|rotates|rotated|rotating)\s+(?:yourself\s+|your\s+body\s+)?"
    rf"(?:(?:by\s+)?(?:about\s+)?{_DEGREES}\s+)?(?:to\s+(?:the|my|your)\s+)?{_SIDE}"
    rf"(?:\s+(?:by\s+)?(?:about\s+)?{_DEGREES})?",
    re.IGNORECASE,
)
_MOVE_STEP = re.compile(
    r"\b(?:walk|walks|walked|walking|move|moves|moved|moving|step|steps|go|goes|going|head|heads)\s+"
    r"(?:\w+\s+){0,2}?(forward|forwards|ahead|straight|back|backward|backwards)\b"
    r"(?:\s+(?:by\s+|for\s+)?(?:about\s+)?(\d+(?:\.\d+)?)\s*(?:m|meters?|metres?)\b)?",
    re.IGNORECASE,
)
# A move not yet made ("if you turn", "after turning", "you turn left and walk"), not "did I turn".
_HYPOTHETICAL = re.compile(
    r"\b(?:if|suppose|supposing|imagine|were to|after (?:i |you )?(?:turn|turning|rotat\w*|walk\w*|mov\w*))\b"
    r"|(?<!did )\b(?:you|i|we) (?:then )?(?:turn|rotate|walk|move|step|go)\b"
    # an imperative after a comma: "Standing at image 3, turn 180 degrees around, what is ...?"
    r"|(?:^|[,;:]\s*)(?:and\s+)?(?:then\s+)?(?:turn|rotate|walk|move|step|go)\s+(?!did\b)",
    re.IGNORECASE,
)
_MOTION_VERB = re.compile(
    r"\b(?:move|moved|moving|movement|walk|walked|travel(?:l?ed)?|went|step(?:ped)?|shift(?:ed)?|"
    r"turn|turned|rotate|rotated|rotation|displace(?:d|ment)?|translat(?:e|ed|ion)|motion|"
    r"tilt(?:ed)?|pitch(?:ed)?|roll(?:ed)?|pan(?:ned)?|yaw(?:ed)?)\b",
    re.IGNORECASE,
)
_TURN_VERB = re.compile(r"\b(?:turn|turned|turning|rotate|rotated|rotating|rotation|face|facing)\b", re.I)
_MOVE_VERB = re.compile(r"\b(?:move|moved|moving|movement|walk|walked|travel\w*|went|step\w*|go)\b", re.I)

# The direction asked about: "what is to your right", "what is to my behind", "behind you",
# "to the left of the orange ball", "in front of you".
_OBJECT = (
    r"(?P<object>(?:the|a|an)\s+[a-z][a-z\- ]*?)"
    r"(?=\s*(?:\?|,|\.|$|\bfrom\b|\bin\b|\bwhen\b|\bafter\b|\bif\b))"
)
# A diagonal, hyphenated or not: "front-left", "front left", "back-right", "behind-left", "rear right".
_DIAGONAL = r"(?:front|forward|back|behind|rear)[- ](?:left|right)"
_SIDE_OF_OBJECT = re.compile(
    rf"(?:\b(?:to|on|at|in)\s+the\s+(?P<side>{_DIAGONAL}|left|right)|\b(?P<bare>{_DIAGONAL}))"
    rf"\s+(?:side\s+)?of\s+{_OBJECT}",
    re.IGNORECASE,
)
# "behind the ball", "behind of the ball" (a released wording), "in front of the ball".
_DEPTH_OF_OBJECT = re.compile(rf"\b(?P<side>behind(?:\s+of)?|in front of)\s+{_OBJECT}", re.IGNORECASE)
_DIAGONAL_OF_ME = re.compile(
    rf"\b(?:to|on|at)\s+(?:my|your|our|the camera's|the viewer's)\s+(?P<side>{_DIAGONAL})\b"
    rf"|\b(?P<bare>{_DIAGONAL})\s+of\s+(?:me|you|us|myself|yourself)\b",
    re.IGNORECASE,
)
_DIRECTION_OF_ME = (
    ("behind", re.compile(
        r"\b(?:to|at|on)\s+(?:my|your|our)\s+(?:behind|back|rear)\b|\bbehind\s+(?:me|you|us|myself|yourself)\b"
        r"|\bbehind\s+the\s+(?:camera|viewer|photographer|person)\b|\bopposite direction\b"
        r"|\bturn(?:ed)?\s+around\b(?!.*\b(?:left|right|front)\b)",
        re.IGNORECASE,
    )),
    ("left", re.compile(
        r"\b(?:to|on|at)\s+(?:my|your|our|the camera's|the viewer's)\s+left\b|\bleft of (?:me|you)\b"
        r"|\b(?:my|your) left(?:-hand)?(?: side)?\b",
        re.IGNORECASE,
    )),
    ("right", re.compile(
        r"\b(?:to|on|at)\s+(?:my|your|our|the camera's|the viewer's)\s+right\b|\bright of (?:me|you)\b"
        r"|\b(?:my|your) right(?:-hand)?(?: side)?\b",
        re.IGNORECASE,
    )),
    ("front", re.compile(
        r"\bin front of (?:me|you|us)\b|\bahead of (?:me|you|us)\b|\b(?:directly|straight) ahead\b"
        r"|\bfacing (?:me|you)\b|\bin front\b(?! of)"
        r"|\b(?:to|at|on)\s+(?:my|your|our)\s+front\b(?![- ](?:left|right))",  # "what is to my front"
        re.IGNORECASE,
    )),
)  # fmt: skip
_RELATION = re.compile(
    r"\bimage\s+(?P<later>\d+)\s+(?:was|is)\s+taken\s+after\s+(?:turning|rotating)\s+(?:the\s+camera\s+)?"
    r"(?:by\s+)?(?P<degrees>\d+(?:\.\d+)?)\s*(?:°|degrees?|deg\b)\s+(?:to\s+the\s+)?"
    r"(?P<side>left|right|clockwise|counter-?clockwise|anti-?clockwise)"
    r".*?\bimage\s+(?P<earlier>\d+)",
    re.IGNORECASE,
)
_OCCLUSION = re.compile(
    r"\b(?:occlud\w*|hidden|hides?|hiding|block(?:s|ed|ing)?\s+(?:the\s+)?view|obstruct\w*|visible|invisible"
    r"|can(?:not|'t)\s+(?:be\s+)?see\w*|not\s+(?:be\s+)?seen\b)",
    re.IGNORECASE,
)
_OBJECT_PERSPECTIVE = re.compile(
    r"\b(?:at|from|in)\s+(?:the\s+)?(?:position|place|location|spot|perspective|viewpoint)\s+of\s+(?:the|a|an)\s+"
    r"|\bwhere\s+the\s+[a-z ]+?\s+is\b|\bfrom\s+the\s+[a-z ]+?'s\s+(?:perspective|point of view|viewpoint)\b"
    r"|\b(?:you|i)\s+(?:are|am)\s+(?:standing|sitting|positioned|located|placed)\s+"
    r"(?:at|on|in|next to|beside|behind)\s+the\s+"
    r"(?![a-z ]*\b(?:viewpoint|view|image|photo|picture|camera|position where)\b)",
    re.IGNORECASE,
)
_DISTANCE_TARGET = re.compile(
    r"\b(?:closer|nearer|farther|further)\s+(?:to|from)\s+(?:or\s+\w+\s+(?:to|from)\s+)?"
    r"(?P<object>(?:the|a|an)\s+[a-z][a-z\- ]*?)(?=\s*(?:\?|,|\.|$|\bthan\b|\bafter\b|\bwhen\b|\bif\b))",
    re.IGNORECASE,
)
_DISTANCE = re.compile(r"\b(?:closer|farther|further|nearer|approach\w*|away from|distance)\b", re.IGNORECASE)


def _side_word(word: str) -> Literal["left", "right", "around"]:
    word = word.lower().replace("-", "")
    if word in ("counterclockwise", "anticlockwise", "left"):
        return "left"
    if word in ("clockwise", "right"):
        return "right"
    return "around"


def pose_steps(text: str) -> list[PoseStep]:
    """The turns and moves a text asks for, in order ("turn 180 degrees around, ..." is one turn)."""
    found: list[tuple[int, PoseStep]] = []
    for match in _TURN_STEP.finditer(text):
        before, side, after = match.groups()
        side = _side_word(side)
        if side == "around":
            found.append((match.start(), PoseStep(kind="turn", side="around", degrees=180.0)))
        else:
            found.append(
                (match.start(), PoseStep(kind="turn", side=side, degrees=float(before or after or 90)))
            )
    for match in _MOVE_STEP.finditer(text):
        way = "backward" if match.group(1).lower().startswith("back") else "forward"
        meters = float(match.group(2)) if match.group(2) else None
        found.append((match.start(), PoseStep(kind="move", side=way, meters=meters)))
    return [step for _, step in sorted(found, key=lambda pair: pair[0])]


def _direction_name(words: str) -> Direction:
    """ "behind of" -> "behind", "in front of" -> "front", "rear-left" / "front right" -> diagonals."""
    words = " ".join(words.lower().replace("-", " ").split())
    if words in ("behind", "behind of"):
        return "behind"
    if words == "in front of":
        return "front"
    if " " in words:
        depth, side = words.split(" ")
        return f"{'front' if depth in ('front', 'forward') else 'back'}-{side}"  # type: ignore[return-value]
    return words  # type: ignore[return-value]


def _asked_direction(ask: str) -> tuple[Direction | None, str | None]:
    """The last direction the ask names, and the object it is relative to (None: relative to me)."""
    candidates: list[tuple[int, Direction, str | None]] = []
    for pattern in (_SIDE_OF_OBJECT, _DEPTH_OF_OBJECT):
        for match in pattern.finditer(ask):
            side = match.group("side") or match.groupdict().get("bare")
            candidates.append((match.start(), _direction_name(side), " ".join(match.group("object").split())))
    for match in _DIAGONAL_OF_ME.finditer(ask):
        candidates.append((match.start(), _direction_name(match.group("side") or match.group("bare")), None))
    for name, pattern in _DIRECTION_OF_ME:
        for match in pattern.finditer(ask):
            if not any(start <= match.start() < start + 16 for start, _, _ in candidates):  # "my front-left"
                candidates.append((match.start(), name, None))  # type: ignore[arg-type]
    if not candidates:
        return None, None
    _, direction, obj = max(candidates, key=lambda c: c[0])
    return direction, obj


def _asked_view(ask: str, num_images: int) -> int | None:
    for match in _ASKED_FROM.finditer(ask):
        views = view_references(ask[match.end() :], num_images)
        if views:
            return views[0]
    views = view_references(ask, num_images)
    return views[0] if views else None


def _relations(setup: list[str]) -> list[ViewRelation]:
    relations = []
    for sentence in setup:
        for match in _RELATION.finditer(sentence):
            side = _side_word(match.group("side"))
            relations.append(
                ViewRelation(
                    earlier=int(match.group("earlier")),
                    later=int(match.group("later")),
                    side="left" if side == "left" else "right",
                    degrees=float(match.group("degrees")),
                )
            )
    return relations


def parse_question(
    question: str, num_images: int | None = None, item_id: str | None = None
) -> QuestionIntent:
    """The question's intent (see the module docstring). Views are 1-based as in the question."""
    views_known = num_images if num_images else 10
    intent = _read_parts(question, views_known, item_id)
    intent.reading = read_question(question, num_images)
    if intent.reading.is_camera:
        return _from_reading(intent, intent.reading)
    for family_of in (_object_perspective, _what_if, _self_movement, _occlusion, _relative_direction):
        if family_of(intent, views_known):
            return intent
    intent.asked_view = _asked_view(intent.ask, views_known)
    return intent


def _read_parts(question: str, views_known: int, item_id: str | None) -> QuestionIntent:
    """Everything read off the text before the family is decided (the family is "unknown" here)."""
    # Options from the text as asked (an option ends at its line's end), the rest with spaces collapsed.
    raw_stem, options = split_options(question.strip())
    stem = " ".join(raw_stem.split())
    _, setup, ask = _parts(stem)
    relations = _relations(setup)
    steps = pose_steps(ask) if _HYPOTHETICAL.search(ask) else []
    direction, target = _asked_direction(_after_last_step(ask, steps))
    return QuestionIntent(
        text=question.strip(),
        setting=setting_from_id(item_id) or _setting_from_words(stem, relations),
        family="unknown",
        ask=ask,
        steps=steps,
        direction=direction,
        target_object=target,
        relations=relations,
        mentioned_views=list(dict.fromkeys(view_references(ask, views_known))),
        options=options,
    )


# Each family rule below fills the intent and returns True when the question is of its family; they
# are tried in parse_question's order (an object's perspective first: it also names directions).

_NO_OBJECT_TOOL = (
    "an object-perspective question (standing at a named object, facing another) needs that "
    "object's position and facing; no tool locates objects, so the offline planner cannot "
    "write a program for it"
)
_NO_OCCLUSION_TOOL = (
    "an occlusion question (what hides what, what is visible) is about objects in the "
    "photos; no tool output states it in words, so only a vision model can answer it"
)


def _of_family(
    intent: QuestionIntent, family: Family, views_known: int, offline_reason: str | None = None
) -> bool:
    intent.family = family
    intent.asked_view = _asked_view(intent.ask, views_known)
    intent.offline_reason = offline_reason
    return True


def _object_perspective(intent: QuestionIntent, views_known: int) -> bool:
    found = _OBJECT_PERSPECTIVE.search(intent.ask)
    return bool(found) and _of_family(intent, "object_perspective", views_known, _NO_OBJECT_TOOL)


def _what_if(intent: QuestionIntent, views_known: int) -> bool:
    if not intent.steps:
        return False
    ask, options = intent.ask, intent.options
    asks_distance = bool(_DISTANCE.search(ask)) or any(_DISTANCE.search(o) for o in options.values())
    intent.comparison = "distance" if asks_distance else None
    target = _DISTANCE_TARGET.search(ask) or next(
        (m for m in map(_DISTANCE_TARGET.search, options.values()) if m), None
    )
    if intent.comparison and target and intent.target_object is None:
        intent.target_object = " ".join(target.group("object").split())
    return _of_family(intent, "what_if", views_known)


def _self_movement(intent: QuestionIntent, views_known: int) -> bool:
    ask, mentions = intent.ask, intent.mentioned_views
    if not _MOTION_VERB.search(ask) or intent.direction is not None:
        return False
    if len(mentions) >= 2:
        _as_self_movement(intent, (mentions[0], mentions[1]), ask)
        return True
    if not mentions and re.search(r"\bcamera\b|\bdid (?:i|you|we)\b|\bfrom\b.*\bto\b", ask, re.IGNORECASE):
        _as_self_movement(intent, (1, 2), ask)  # "how did the camera move?": the first pair
        return True
    return False


def _occlusion(intent: QuestionIntent, views_known: int) -> bool:
    found = _OCCLUSION.search(intent.ask)
    return bool(found) and _of_family(intent, "occlusion", views_known, _NO_OCCLUSION_TOOL)


def _relative_direction(intent: QuestionIntent, views_known: int) -> bool:
    return intent.direction is not None and _of_family(intent, "relative_direction", views_known)


def _after_last_step(ask: str, steps: list[PoseStep]) -> str:
    """The ask after its last turn or move ("... turn around, what is to your left?" -> "what is ...")."""
    if not steps:
        return ask
    ends = [m.end() for m in _TURN_STEP.finditer(ask)] + [m.end() for m in _MOVE_STEP.finditer(ask)]
    return ask[max(ends) :] if ends else ask


_ASKED_OF_AXIS: dict[str, AskedMotion] = {"yaw": "turn", "pitch": "tilt", "roll": "roll"}


def _from_reading(intent: QuestionIntent, reading: QuestionReading) -> QuestionIntent:
    """A camera question, as its reading says (options lead, the stem gives the pair): the planner,
    the checks and the answerers take the pair and the quantity from here."""
    intent.family = "self_movement"
    intent.steps, intent.direction, intent.target_object, intent.comparison = [], None, None, None
    mentioned = intent.mentioned_views
    pair = reading.views or (tuple(mentioned[:2]) if len(mentioned) >= 2 else (1, 2))
    intent.motion_pair = pair  # type: ignore[assignment]
    intent.asked_view = pair[0]
    intent.motion_frame = "gravity" if reading.frame is not None and reading.frame.kind == "room" else "image"
    axes = {getattr(claim, "axis", None) for claim in reading.options.values()} - {None}
    if reading.quantity == "rotation":
        stem_asks = asked_motion(intent.ask)
        of_options = _ASKED_OF_AXIS[axes.pop()] if len(axes) == 1 else "any"  # type: ignore[index]
        intent.motion_asked = stem_asks if stem_asks in ("turn", "tilt", "roll") else of_options
        intent.asks_turn_only = intent.motion_asked == "turn" or (not reading.options and not axes)
    elif reading.quantity in ("translation", "position"):
        intent.motion_asked = "move"
    else:
        intent.motion_asked = asked_motion(intent.ask)
    return intent


def _as_self_movement(intent: QuestionIntent, pair: tuple[int, int], ask: str) -> QuestionIntent:
    intent.family = "self_movement"
    intent.motion_pair = pair
    intent.asked_view = pair[0]
    intent.asks_turn_only = bool(_TURN_VERB.search(ask)) and not _MOVE_VERB.search(ask)
    intent.motion_asked = "turn" if intent.asks_turn_only else asked_motion(ask)
    intent.motion_frame = asked_frame(intent.text)
    return intent


__all__ = [
    "Direction",
    "Family",
    "PoseStep",
    "QuestionIntent",
    "Setting",
    "ViewRelation",
    "parse_question",
    "pose_steps",
    "setting_from_id",
    "view_references",
]
