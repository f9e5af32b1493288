"""A combinatorial corpus of camera questions in many wordings, each with the reading it must get.

The wordings are independent lists (tests/data/paraphrases/): stems per quantity asked, pair
constructions, image nouns, ways to name a view, option wordings per claim, frame and roll notes.
Each list was split once, by whole entries and with a fixed seed (`split_lists`), into a tuning
part and a held-out part, kept in two files (`wordings_tuning.json`, `wordings_heldout.json`), so
a held-out item uses only wordings that no tuning item contains. Only the option layouts (MMSI's
"Options: A: ..., B: ..." and "A. ..." lines), the number words and the implicit pair of a
two-image question are shared: they are structure, not wording.

An item is asked from a spec (`AskSpec`: image count, the ordered pair A -> B, the quantity, the
options' claims and which one holds) and carries what a correct reading gives: the pair, the
quantity, each option's claim as a plain dict (the kinds of shared/questions/claims.py:
translation / position `ways`, rotation `axis` and `sense`, still), and for the items that must
abstain the kind of reason ("pair", "option", "quantity"). The benches build specs from scenes
whose true motion they know (bench/paraphrase_*.py); `text_corpus` draws random specs for the
reading alone.
"""

from __future__ import annotations

import json
import random
import zlib
from dataclasses import asdict, dataclass, field
from pathlib import Path

DATA_DIR = Path(__file__).resolve().parents[1] / "data" / "paraphrases"
SPLITS = ("tuning", "heldout")
SPLIT_SEED = 34
HELDOUT_SHARE = 0.4
LETTERS = "ABCD"
NUMBER_WORDS = {1: "one", 2: "two", 3: "three", 4: "four", 5: "five"}
ORDINALS = {1: "first", 2: "second", 3: "third", 4: "fourth", 5: "fifth"}
NTH = {1: "1st", 2: "2nd", 3: "3rd", 4: "4th", 5: "5th"}
LAST_ONLY = ("the last {noun}", "the final {noun}")  # name view n only when n is the last view
QUANTITIES = ("translation", "rotation", "position", "motion")
ABSTAIN_KINDS = ("pair", "option", "quantity")
THREE_VIEWS = " among {A}, {B} and {C}"  # structure of the ambiguous-pair items (no order given)


def split_lists(lists: dict[str, list], seed: int = SPLIT_SEED) -> tuple[dict, dict]:
    """(tuning, held-out): every list's entries, each with an id (`name.NN`, NN its place in the
    authored list), split by whole entries; each side keeps at least one entry of every list."""
    tuning: dict[str, list] = {}
    heldout: dict[str, list] = {}
    for name in sorted(lists):
        entries = [{"id": f"{name}.{i:02d}", "text": text} for i, text in enumerate(lists[name])]
        order = list(range(len(entries)))
        random.Random(seed * 1_000_003 + zlib.crc32(name.encode())).shuffle(order)
        count = min(len(entries) - 1, max(1, round(len(entries) * HELDOUT_SHARE)))
        held = set(order[:count])
        heldout[name] = [e for i, e in enumerate(entries) if i in held]
        tuning[name] = [e for i, e in enumerate(entries) if i not in held]
    return tuning, heldout


def load_wordings(split: str) -> dict[str, list[dict]]:
    if split not in SPLITS:
        raise ValueError(f"split must be one of {SPLITS}, not {split!r}")
    return json.loads((DATA_DIR / f"wordings_{split}.json").read_text(encoding="utf-8"))


@dataclass(frozen=True)
class ClaimSpec:
    """One option's claim: translation / position (`ways`), rotation (`axis`, `sense`), still."""

    kind: str
    ways: tuple[str, ...] = ()
    axis: str | None = None
    sense: str | None = None

    def as_dict(self) -> dict:
        if self.kind in ("translation", "position"):
            return {"kind": self.kind, "ways": list(self.ways)}
        if self.kind == "rotation":
            return {"kind": "rotation", "axis": self.axis, "sense": self.sense}
        return {"kind": self.kind}

    def wording_list(self) -> tuple[str, str]:
        """(the option list that words this claim, the key of its text in an entry)."""
        if self.kind == "still":
            return "option.still", "still"
        if self.kind == "rotation":
            return f"option.rotation.{self.axis}", str(self.sense)
        (way,) = self.ways
        if self.kind == "position":
            return "option.position", way
        axis = {"left": "lateral", "right": "lateral", "up": "vertical", "down": "vertical"}.get(way, "depth")
        return f"option.translation.{axis}", way


TRANSLATIONS = tuple(
    ClaimSpec("translation", (w,)) for w in ("left", "right", "up", "down", "forward", "backward")
)
POSITIONS = tuple(ClaimSpec("position", (w,)) for w in ("left", "right", "up", "down", "forward", "backward"))
ROTATIONS = tuple(
    ClaimSpec("rotation", axis=a, sense=s)
    for a, senses in (
        ("yaw", ("left", "right")),
        ("pitch", ("up", "down")),
        ("roll", ("clockwise", "counterclockwise")),
    )
    for s in senses
)
STILL = ClaimSpec("still")


@dataclass(frozen=True)
class AskSpec:
    image_count: int
    pair: tuple[int, int]  # A -> B: the view the camera started at, the one it ended at
    quantity: str  # translation / rotation / position / motion (mixed options)
    claims: tuple[ClaimSpec, ...]  # the options, in letter order
    truth: int | None = None  # index of the claim that holds (None: text only)
    abstain: str | None = None  # an ABSTAIN_KINDS item: how the wording is made ambiguous
    third: int | None = None  # the extra view an ambiguous-pair item names


@dataclass
class ParaphraseItem:
    id: str
    split: str
    text: str
    image_count: int
    views: tuple[int, int] | None  # the ordered pair a correct reading gives (None: must abstain on it)
    quantity: str | None  # None when the stem and the options disagree (must abstain)
    options: dict[str, dict]  # letter -> expected claim ({"kind": "two claims"}: must abstain)
    answer: str | None  # the letter that holds, when the spec says
    abstain: str | None  # the kind of reason a correct reading abstains with
    wording_ids: list[str] = field(default_factory=list)

    def as_json(self) -> dict:
        return asdict(self)


class _Phraser:
    """Words one spec with entries drawn from one split's lists, remembering which it used."""

    def __init__(self, wordings: dict[str, list[dict]], rng: random.Random) -> None:
        self.wordings, self.rng, self.used = wordings, rng, []
        self.option_entries: dict[str, dict] = {}  # one wording per option list within an item

    def pick(self, name: str, usable=lambda text: True) -> str | dict:
        entries = [e for e in self.wordings[name] if usable(e["text"])]
        entry = self.rng.choice(entries)
        self.used.append(entry["id"])
        return entry["text"]

    def reference(self, view: int, count: int, noun: str, style: str) -> str:
        if style in LAST_ONLY and view != count:
            style = str(self.pick("reference", lambda t: t not in LAST_ONLY))
        return style.format(noun=noun, n=view, word=NUMBER_WORDS[view], ordinal=ORDINALS[view], nth=NTH[view])

    def option(self, claim: ClaimSpec) -> str:
        name, key = claim.wording_list()
        if name not in self.option_entries:
            self.option_entries[name] = self.pick(name)  # type: ignore[assignment]
        return str(self.option_entries[name][key])


def _sentence(text: str) -> str:
    return text[:1].upper() + text[1:] if text else text


def _stem(spec: AskSpec, phraser: _Phraser, refs: dict[str, str]) -> str:
    rng = phraser.rng
    if spec.quantity == "position":
        return _sentence(str(phraser.pick("stem.position")).format(**refs))
    stem_list = {"translation": "stem.translation", "rotation": "stem.rotation"}.get(
        spec.quantity, "stem.motion"
    )
    if spec.abstain == "quantity":  # a stem that names the other quantity than every option states
        stem_list = "stem.rotation" if spec.quantity == "translation" else "stem.translation"
    elif spec.quantity != "motion" and rng.random() < 0.35:
        stem_list = "stem.motion"  # a plain "how did it move?": the options say which quantity
    stem = str(phraser.pick(stem_list))
    if spec.abstain == "pair":
        span = THREE_VIEWS.format(**refs) if rng.random() < 0.5 else ""
        return _sentence(stem.format(span=span))
    if spec.image_count == 2 and spec.pair == (1, 2) and rng.random() < 0.15:
        return _sentence(stem.format(span=""))  # two images, no pair named: 1 -> 2
    preamble, span = (part.strip() for part in str(phraser.pick("construction")).split("|"))
    asked = _sentence(stem.format(span=" " + span.format(**refs) if span else ""))
    return (_sentence(preamble.format(**refs)) + " " + asked) if preamble else asked


def phrase(
    spec: AskSpec,
    wordings: dict[str, list[dict]],
    split: str,
    item_id: str,
    rng: random.Random,
    layout: str | None = None,
) -> ParaphraseItem:
    """The spec asked in words from `wordings`, with the reading a correct reader gives; the
    options laid out as `layout` says ("mmsi": "Options: A: ...", "lines": "A. ..."; None: either)."""
    phraser = _Phraser(wordings, rng)
    noun, style = str(phraser.pick("noun")), str(phraser.pick("reference"))
    a, b = spec.pair
    refs = {"A": phraser.reference(a, spec.image_count, noun, style)}
    refs["B"] = phraser.reference(b, spec.image_count, noun, style)
    if spec.third is not None:
        refs["C"] = phraser.reference(spec.third, spec.image_count, noun, style)
    sentences = []
    if spec.abstain != "pair" and rng.random() < 0.3:
        sentences.append(_sentence(str(phraser.pick("frame_note")).format(**refs)))
    if any(c.axis == "roll" for c in spec.claims) and rng.random() < 0.6:
        sentences.append(str(phraser.pick("roll_note")))
    sentences.append(_stem(spec, phraser, refs))
    texts = [phraser.option(claim) for claim in spec.claims]
    expected = {LETTERS[i]: claim.as_dict() for i, claim in enumerate(spec.claims)}
    if spec.abstain == "option":  # one option says two things at once
        i = rng.randrange(len(texts))
        other = rng.choice([c for c in spec.claims if c != spec.claims[i]])
        texts[i] = f"{texts[i]} or {_lower_first(phraser.option(other))}"
        expected[LETTERS[i]] = {"kind": "two claims"}
    return ParaphraseItem(
        id=item_id,
        split=split,
        text=" ".join(sentences) + _options_block(texts, rng, layout),
        image_count=spec.image_count,
        views=None if spec.abstain == "pair" else spec.pair,
        quantity=None if spec.abstain == "quantity" else spec.quantity,
        options=expected,
        answer=None if spec.truth is None else LETTERS[spec.truth],
        abstain=spec.abstain,
        wording_ids=phraser.used,
    )


def _lower_first(text: str) -> str:
    return text if text[1:2].isupper() else text[:1].lower() + text[1:]  # keep "UP", lower "A clockwise"


def _options_block(texts: list[str], rng: random.Random, layout: str | None) -> str:
    if layout is None:
        layout = "mmsi" if rng.random() < 0.5 else "lines"
    if layout == "mmsi":  # MMSI-Bench's published schema
        return "\nOptions: " + ", ".join(f"{LETTERS[i]}: {t}" for i, t in enumerate(texts))
    return "".join(f"\n{LETTERS[i]}. {t}" for i, t in enumerate(texts))


def quantity_of(claims: tuple[ClaimSpec, ...]) -> str:
    """The quantity a set of options asks: their kinds (still says nothing), "motion" when mixed."""
    kinds = {c.kind for c in claims if c.kind != "still"}
    return kinds.pop() if len(kinds) == 1 else "motion"


def random_spec(rng: random.Random, abstain: str | None = None) -> AskSpec:
    """A spec with random views, quantity and distinct options (the first one holds)."""
    count = rng.choice((2, 2, 3, 4))
    a, b = rng.sample(range(1, count + 1), 2)
    quantity = rng.choice(QUANTITIES)
    if abstain == "quantity":
        quantity = rng.choice(("translation", "rotation"))
    if abstain == "pair" and quantity == "position":  # a position stem always names both views
        quantity = "motion"
    if abstain == "pair":
        count = max(count, 3)
        a, b = rng.sample(range(1, count + 1), 2)
    pool = {
        "translation": [*TRANSLATIONS, STILL],
        "rotation": [*ROTATIONS, STILL],
        "position": list(POSITIONS),
    }
    if quantity == "motion":
        claims = rng.sample(TRANSLATIONS, 2) + rng.sample(ROTATIONS, 2)
    else:
        claims = rng.sample(pool[quantity], 4)
    rng.shuffle(claims)
    third = next(v for v in range(1, count + 1) if v not in (a, b)) if abstain == "pair" else None
    return AskSpec(count, (a, b), quantity_of(tuple(claims)), tuple(claims), 0, abstain, third)


def text_corpus(
    split: str, count: int = 600, seed: int = 0, abstain_share: float = 0.12
) -> list[ParaphraseItem]:
    """`count` items of one split for the reading alone (the last `abstain_share` must abstain)."""
    wordings = load_wordings(split)
    rng = random.Random(f"{seed}:{split}")
    items = []
    abstaining = round(count * abstain_share)
    for index in range(count):
        kind = ABSTAIN_KINDS[index % len(ABSTAIN_KINDS)] if index >= count - abstaining else None
        spec = random_spec(rng, kind)
        items.append(phrase(spec, wordings, split, f"{split}-{index:04d}", rng))
    return items
