"""The quantity a camera question asks, on development wordings written for this file (not taken
from the paraphrase corpus): stems for each quantity (where the camera went, how it turned, where one
photo was taken from relative to another, any change), put with pair constructions and asides that set
a quantity aside or restrict the question to one; and options read in part, whose verbs name their
kind though their claim is not read (shared/questions/reading.py: the options lead, and what they are
known to state is the quantity when the stem says none with a word of one kind, never certainly).
"""

from __future__ import annotations

import itertools

import pytest

from shared.questions.lexicon import kinds_named, read_phrase
from shared.questions.reading import read_question
from tests.test_option_lexicon import short

# ---- stems: each asks one quantity, whatever pair construction it is put with --------------------

PAIR_SPANS = (
    ("from image 1 to image 2", (1, 2), 2),
    ("between the first and the second photo", (1, 2), 2),
    ("going from picture 2 to picture 3", (2, 3), 3),
    ("between shot 1 and shot 3", (1, 3), 3),
    ("from the first view to the third", (1, 3), 3),
)
# "{p}": the pair's words in place; "{P}": the same opening the sentence.
STEMS: dict[str, tuple[str, ...]] = {
    "translation": (
        "Where did the camera go {p}?",
        "Which way did the camera move {p}?",
        "In which direction did the photographer walk {p}?",
        "How was the camera displaced {p}?",
        "Which way did the camera's position shift {p}?",
        "In what direction did the camera travel {p}?",
        "Ignoring rotation, how did the camera move {p}?",
        "Which way did the photographer step {p}?",
        "What translation did the camera undergo {p}?",
        "How did the camera's location change {p}?",
        "Which way was the camera moved {p}?",
        "Rotation aside, which way did the camera go {p}?",
        "Disregarding any turning, in which direction was the camera translated {p}?",
        "Which direction did the shooter move in {p}?",
        "How did the camera's position change {p}?",
        "Which way did the camera slide {p}?",
        "What was the direction of the camera's movement {p}?",
        "In which direction was the camera carried {p}?",
        "Which way did the photographer walk {p}, ignoring where the camera pointed?",
        "How did the viewpoint shift {p}?",
        "Which best describes the camera's translation {p}?",
        "Where did the photographer move to {p}?",
        "Which way was the camera relocated {p}?",
        "{P}, which way did the camera move?",
        "{P}, how was the camera repositioned?",
    ),
    "rotation": (
        "Which way did the camera turn {p}?",
        "How did the camera rotate {p}?",
        "How did the camera's orientation change {p}?",
        "How did the photographer turn the camera {p}?",
        "What rotation did the camera undergo {p}?",
        "How did the camera's viewing direction change {p}?",
        "In which direction did the camera pan, tilt or roll {p}?",
        "Without counting any movement, how did the camera turn {p}?",
        "Which way did the lens point {p}?",
        "How did the direction the camera faces change {p}?",
        "Which way was the camera rotated {p}?",
        "How did the camera's aim change {p}?",
        "Which way did the camera look {p}?",
        "Ignoring translation, how did the camera's heading change {p}?",
        "How was the camera reoriented {p}?",
        "Where did the camera point {p}?",
        "Which way did the camera swing {p}?",
        "What happened to the camera's orientation {p}?",
        "How did the camera's attitude change {p}?",
        "{P}, which way did the camera turn?",
        "{P}, how did the line of sight change?",
        "Position aside, how did the camera rotate {p}?",
        "How did the camera tilt or pan {p}?",
    ),
    "motion": (
        "How did the camera move or turn {p}?",
        "Did the camera move and rotate {p}, and how?",
        "How did the camera's position and viewing direction change {p}?",
        "How did the camera's pose change {p}?",
    ),
}
POSITION_STEMS = (
    "Where was {B} taken from, relative to {A}?",
    "Relative to the camera of {A}, where was the camera for {B}?",
    "Where is the camera of {B} relative to the camera of {A}?",
    "Where was the photographer standing for {B}, compared with {A}?",
    "Compared with {A}, from which side was {B} taken?",
    "Where does the viewpoint of {B} lie relative to that of {A}?",
    "In which direction from the camera of {A} is the camera of {B}?",
    "What is the position of the camera of {B} relative to the camera of {A}?",
    "Where was the camera placed for {B}, relative to {A}?",
    "Where is {B}'s camera, as seen from {A}'s camera?",
    "Taking {A} as the reference, where was {B} photographed from?",
    "Where would you find the camera of {B}, from the camera of {A}?",
    "Which direction is the camera position of {B} from that of {A}?",
    "How is the camera of {B} positioned relative to the camera of {A}?",
    "{B} was taken from where, relative to {A}?",
    "Where did the photographer stand to take {B}, relative to {A}?",
    "With the camera of {A} as origin, where was {B} captured?",
    "Where is the shooting location of {B} compared with {A}?",
    "Relative to {A}'s viewpoint, where is {B}'s viewpoint?",
)
POSITION_REFS = (("image 1", "image 2", (1, 2), 2), ("the first photo", "the second photo", (1, 2), 2))
POSITION_REFS += (("picture 3", "picture 1", (3, 1), 3),)


def _stem_cases() -> list[tuple[str, tuple[int, int], int, str]]:
    cases = []
    for quantity, stems in STEMS.items():
        for stem, (span, views, count) in itertools.product(stems, PAIR_SPANS):
            text = stem.format(p=span, P=span[:1].upper() + span[1:])
            cases.append((text, views, count, quantity))
    for stem, (a, b, views, count) in itertools.product(POSITION_STEMS, POSITION_REFS):
        text = stem.format(A=a, B=b)
        cases.append((text[:1].upper() + text[1:], views, count, "position"))
    return cases


def test_every_development_stem_asks_its_quantity_of_its_pair() -> None:
    wrong = []
    for text, views, count, quantity in _stem_cases():
        reading = read_question(text, count)
        if (reading.quantity, reading.views) != (quantity, views):
            wrong.append((text, reading.quantity, reading.views))
    assert not wrong, f"{len(wrong)} misread:\n" + "\n".join(map(str, wrong[:40]))


# Stems written with their pair in place (image 1 -> image 2 of two photos).
WHOLE_STEMS: list[tuple[str, str]] = [
    # position
    ("Where was the second shot's camera, relative to the first shot's camera?", "position"),
    ("From the first camera's point of view, where is the second camera?", "position"),
    ("Where, relative to image 1, did the photographer take image 2?", "position"),
    ("Which side of image 1's camera is image 2's camera on?", "position"),
    ("How is image 2's camera placed with respect to image 1's camera?", "position"),
    ("Where is image 2's capture point relative to image 1's?", "position"),
    ("Image 2's camera is where, relative to image 1's?", "position"),
    ("Where does the camera of image 2 stand relative to that of image 1?", "position"),
    ("If image 1's camera is the origin, where is image 2's camera?", "position"),
    ("Where was image 2 captured from, seen from image 1's position?", "position"),
    ("What is the direction from image 1's camera to image 2's camera?", "position"),
    ("In what direction does image 2's camera lie from image 1's camera?", "position"),
    ("Where is the viewpoint of image 2 with respect to image 1?", "position"),
    ("Which way is image 2's camera from image 1's?", "position"),
    ("Relative to the first camera, the second camera is located where?", "position"),
    ("Where did the second picture get taken, relative to the first?", "position"),
    ("Describe where image 2's camera is relative to image 1's camera.", "position"),
    ("Which of these describes where photo 2 was taken from, relative to photo 1?", "position"),
    (
        "Where is the position of the camera that took image 2, relative to the one that took image 1?",
        "position",
    ),
    ("Relative to where image 1 was shot, where was image 2 shot?", "position"),
    ("Where is the camera that took photo 2, compared with the camera that took photo 1?", "position"),
    ("Compared with the first photo's camera, where does the second photo's camera sit?", "position"),
    ("With photo 1's camera as the reference, what is the location of photo 2's camera?", "position"),
    ("Where is the second photo's vantage point relative to the first's?", "position"),
    ("Where was the shooter for photo 2, relative to the shooter for photo 1?", "position"),
    ("Where did the photographer take photo 2 from, compared with photo 1?", "position"),
    ("Photo 2 was taken from which position relative to photo 1?", "position"),
    ("Relative to photo 1, what position was photo 2 taken from?", "position"),
    # rotation
    ("How did the camera's pointing direction change from image 1 to image 2?", "rotation"),
    ("Which way did the camera's view swing from image 1 to image 2?", "rotation"),
    ("Which rotation did the camera make from image 1 to image 2?", "rotation"),
    ("In what way was the camera turned from image 1 to image 2?", "rotation"),
    ("Which way did the photographer aim the camera in image 2 compared with image 1?", "rotation"),
    ("How did the camera's facing change from image 1 to image 2?", "rotation"),
    ("Which way was the camera facing in image 2, relative to image 1?", "rotation"),
    ("How is the camera in image 2 oriented relative to image 1?", "rotation"),
    ("What rotation takes the camera from image 1 to image 2?", "rotation"),
    ("How did the camera's viewing angle change from image 1 to image 2?", "rotation"),
    ("Which way did the camera's gaze move from image 1 to image 2?", "rotation"),
    ("Which change in orientation occurred from image 1 to image 2?", "rotation"),
    ("Which way did the lens swing from image 1 to image 2?", "rotation"),
    ("How did the camera roll, pan or tilt from image 1 to image 2?", "rotation"),
    ("From image 1 to image 2, how was the camera's direction of view altered?", "rotation"),
    ("How did the camera's angle change from image 1 to image 2?", "rotation"),
    ("Which way did the camera face in image 2 compared with image 1?", "rotation"),
    ("How did where the camera was looking change from image 1 to image 2?", "rotation"),
    ("What turn did the camera make from image 1 to image 2?", "rotation"),
    ("How did the camera rotate in place from image 1 to image 2?", "rotation"),
    ("Regardless of any shift in position, how did the camera turn from image 1 to image 2?", "rotation"),
    ("What was the camera's change in rotation from image 1 to image 2?", "rotation"),
    # translation
    ("How did the camera's position move from image 1 to image 2?", "translation"),
    ("In which direction was the camera displaced from image 1 to image 2?", "translation"),
    ("How did the camera's placement change from image 1 to image 2?", "translation"),
    ("What was the camera's displacement from image 1 to image 2?", "translation"),
    ("How did the photographer reposition from image 1 to image 2?", "translation"),
    (
        "Not considering the direction it faced, where did the camera go from image 1 to image 2?",
        "translation",
    ),
    (
        "Regardless of where it pointed, how did the camera's position change from image 1 to image 2?",
        "translation",
    ),
    ("How did the camera's position differ from image 1 to image 2?", "translation"),
    ("Which way did the shooting position move from image 1 to image 2?", "translation"),
    ("Which way did the camera physically move from image 1 to image 2?", "translation"),
    ("Which way did the camera travel between taking image 1 and image 2?", "translation"),
    ("Where did the photographer walk to from image 1 to image 2?", "translation"),
    ("What was the camera's change in position from image 1 to image 2?", "translation"),
    ("Which direction did the camera translate from image 1 to image 2?", "translation"),
    ("Orientation aside, which way did the camera move from image 1 to image 2?", "translation"),
    ("Where did the camera move from image 1 to image 2, ignoring its rotation?", "translation"),
    ("How did the camera's location shift from image 1 to image 2?", "translation"),
    ("Where was the camera carried from image 1 to image 2?", "translation"),
    ("Which way did the camera's viewpoint move from image 1 to image 2?", "translation"),
    # asides that set a quantity aside, or restrict the question to one
    ("Forget about turning: where did the camera go from image 1 to image 2?", "translation"),
    ("Turning aside, how did the camera move from image 1 to image 2?", "translation"),
    ("Just considering position, how did the camera move from image 1 to image 2?", "translation"),
    ("Only considering where it stood, how did the camera change from image 1 to image 2?", "translation"),
    ("Purely in terms of position, what changed from image 1 to image 2?", "translation"),
    ("In terms of position only, how did the camera change from image 1 to image 2?", "translation"),
    (
        "Apart from any change in where it points, how did the camera move from image 1 to image 2?",
        "translation",
    ),
    ("Leaving its orientation out of it, how did the camera move from image 1 to image 2?", "translation"),
    ("Never mind the rotation, which way did the camera move from image 1 to image 2?", "translation"),
    (
        "Without regard to the direction it faced, where did the camera go from image 1 to image 2?",
        "translation",
    ),
    (
        "How did the camera's position change from image 1 to image 2, regardless of orientation?",
        "translation",
    ),
    ("From image 1 to image 2, which way did the camera shift its position?", "translation"),
    ("Looking only at the camera's location, what changed from image 1 to image 2?", "translation"),
    ("Which way did the camera move its position from image 1 to image 2?", "translation"),
    ("Translation only: which way did the camera go from image 1 to image 2?", "translation"),
    ("What was the camera's direction of travel from image 1 to image 2?", "translation"),
    ("Which way was the camera displaced between image 1 and image 2, ignoring any rotation?", "translation"),
    ("Which way did the camera move, from image 1 to image 2, not counting any turn?", "translation"),
    ("How did the camera change place from image 1 to image 2?", "translation"),
    ("How did the camera change its location from image 1 to image 2?", "translation"),
    ("In terms of rotation only, how did the camera change from image 1 to image 2?", "rotation"),
    ("Looking only at orientation, what changed from image 1 to image 2?", "rotation"),
    (
        "Considering only the direction it faced, how did the camera change from image 1 to image 2?",
        "rotation",
    ),
    ("Forget about position: how did the camera turn from image 1 to image 2?", "rotation"),
    ("Never mind any movement, which way did the camera rotate from image 1 to image 2?", "rotation"),
    ("Apart from changing place, how did the camera's direction change from image 1 to image 2?", "rotation"),
    ("Rotation only: what did the camera do from image 1 to image 2?", "rotation"),
    ("How did the camera change its orientation from image 1 to image 2?", "rotation"),
    ("How did the camera change where it was pointing from image 1 to image 2?", "rotation"),
    ("Which way did the camera change its heading from image 1 to image 2?", "rotation"),
    ("Setting translation aside, how did the camera rotate from image 1 to image 2?", "rotation"),
    ("From image 1 to image 2, in which direction did the camera's view turn?", "rotation"),
    ("What change in the camera's facing direction happened from image 1 to image 2?", "rotation"),
    ("Which way did the camera's optical axis swing from image 1 to image 2?", "rotation"),
    ("How was the camera rotated between image 1 and image 2, ignoring any displacement?", "rotation"),
    ("Which way was the camera looking in image 2 compared with image 1?", "rotation"),
    ("Compared with image 1, where is the camera looking in image 2?", "rotation"),
    ("Compared with image 1, which way does the camera face in image 2?", "rotation"),
    ("Relative to image 1, how is the camera rotated in image 2?", "rotation"),
    ("How does the camera's orientation in image 2 differ from image 1?", "rotation"),
    ("Compared with image 1, where is the camera in image 2?", "position"),
    ("Relative to image 1, where is the camera in image 2?", "position"),
    ("Where is the camera in image 2 relative to image 1?", "position"),
    ("Relative to image 1's camera, where does image 2's camera sit?", "position"),
    ("Where was the camera for image 2, compared with the camera for image 1?", "position"),
    ("In image 2, where is the camera relative to where it was in image 1?", "position"),
    ("How is the camera of image 2 located relative to that of image 1?", "position"),
    ("Where is image 2 taken from compared to image 1?", "position"),
    ("Where was the camera when image 2 was taken, relative to when image 1 was taken?", "position"),
    ("Where did the photographer stand for image 2, relative to image 1?", "position"),
]


@pytest.mark.parametrize(("text", "quantity"), WHOLE_STEMS, ids=[t[:50] for t, _ in WHOLE_STEMS])
def test_whole_stems_ask_their_quantity(text: str, quantity: str) -> None:
    reading = read_question(text, 2)
    assert (reading.quantity, reading.views) == (quantity, (1, 2)), reading.quantity_source


# ---- options partly read: the kinds their verbs name ---------------------------------------------

# A verb of one kind with words the lexicon does not read after it: its kind is named, its claim not.
NAMED_KINDS = [
    ("It rolled in the direction the clock's hands go", {"rotation"}),
    ("It panned toward the window wall", {"rotation"}),
    ("It swivelled toward the doorway", {"rotation"}),
    ("It tilted toward the chandelier", {"rotation"}),
    ("It rolled to the right", {"rotation"}),  # a roll toward a side: the sense is not read
    ("It stepped toward the doorway", {"translation"}),
    ("The camera was hoisted onto the shelf", {"translation"}),
    ("It slid along the counter to the left", {"translation"}),
    ("It moved left and pivoted toward the doorway", {"translation", "rotation"}),
]
# Nothing of a kind is named: an everyday verb alone, a negation, another subject, the scene, a zoom,
# alternatives, or a verb the lexicon does not know.
NO_KIND_NAMED = [
    "It moved somehow",
    "It did not turn toward the doorway",
    "The tripod moved left",
    "The scene slid toward the doorway",
    "It zoomed toward the doorway",
    "It panned toward the doorway or stepped back",
    "It scooched leftish",
]


@pytest.mark.parametrize(("text", "kinds"), NAMED_KINDS)
def test_an_unread_options_verb_names_its_kind(text: str, kinds: set[str]) -> None:
    assert short(read_phrase(text)).startswith("U")  # the claim itself stays unread
    assert kinds_named(text) == kinds


@pytest.mark.parametrize("text", NO_KIND_NAMED)
def test_no_kind_is_named_without_a_verb_of_one_kind_said_of_the_camera(text: str) -> None:
    assert kinds_named(text) == frozenset()


_WEAK_STEM = "What did the camera do from image 1 to image 2?"


def _ask(stem: str, options: list[str]) -> str:
    return stem + "".join(f"\n{letter}. {text}" for letter, text in zip("ABCD", options, strict=False))


@pytest.mark.parametrize(
    ("options", "quantity"),
    [
        # two steps read, two turns whose verbs name a turn: any motion
        (
            ["It moved left", "It moved right", "It panned toward the window", "It tilted toward the lamp"],
            "motion",
        ),
        # two turns read, a step named: any motion
        (["It panned left", "It tilted up", "It stepped toward the door", "It moved right"], "motion"),
        # turns read and named: a rotation
        (["It panned left", "It panned right", "It rolled toward the door", "It tilted up"], "rotation"),
    ],
)
def test_named_kinds_join_the_read_ones_and_are_never_certain(options: list[str], quantity: str) -> None:
    reading = read_question(_ask(_WEAK_STEM, options), 2)
    assert reading.quantity == quantity
    assert not reading.quantity_certain  # an option's kind named, its claim not read


def test_a_stem_of_one_kind_is_not_overruled_by_named_kinds() -> None:
    options = ["It panned left", "It panned right", "It stepped toward the door", "It tilted up"]
    reading = read_question(_ask("Which way did the camera turn from image 1 to image 2?", options), 2)
    assert reading.quantity == "rotation"


def test_an_unread_option_of_no_named_kind_keeps_the_quantity_uncertain() -> None:
    options = ["It moved left", "It moved right", "It moved up", "It scooched leftish"]
    reading = read_question(_ask(_WEAK_STEM, options), 2)
    assert reading.quantity == "translation" and not reading.quantity_certain
    every = read_question(_ask(_WEAK_STEM, [*options[:3], "It moved down"]), 2)
    assert every.quantity == "translation" and every.quantity_certain


def test_a_bare_direction_beside_turns_makes_the_options_ask_any_motion() -> None:
    options = ["It panned left", "It tilted up", "Higher", "Further to the left"]
    reading = read_question(_ask(_WEAK_STEM, options), 2)
    assert reading.quantity == "motion" and not reading.quantity_certain
    assert reading.abstain_reason is not None  # the bare ones read two ways: no answer
    turning = read_question(_ask("Which way did the camera turn from image 1 to image 2?", options), 2)
    assert turning.quantity == "rotation"  # a stem of one kind gives the bare ones theirs
    assert short(turning.options["C"]) == "R pitch up"
