"""Development wordings for the reader, written for this file from the language of camera motion as a
whole (a thesaurus-style sweep, not taken from the paraphrase corpus): option phrases built from
parts, each part carrying its meaning, so every phrase's expected claim follows from how it was put
together; further sweeps in plainer, rarer and operator's words; and near-misses that must stay unread
(the stems are in tests/test_reading_dev_quantity.py).

Options are built as subject + verb + direction (+ a hedge or a frame note): "The photographer" +
"edged" + "a little to the left" + ", as seen from behind the camera" is a step left, whatever the
combination. Verbs that carry their own way ("climbed", "retreated"), noun phrases ("a leftward
shift"), passives ("was swung"), fragments ("further left") and the second shot's place ("the second
shot was taken from further left") are rows of their own. Expected claims are in the short form of
tests/test_option_lexicon.py (``T left``, ``P up``, ``R yaw left``, ``R roll clockwise``, ``S``,
``U``).
"""

from __future__ import annotations

import itertools

import pytest

from shared.questions.lexicon import read_phrase
from shared.questions.reading import read_question
from tests.test_option_lexicon import short

OPPOSITE = {
    "left": "right",
    "right": "left",
    "up": "down",
    "down": "up",
    "forward": "backward",
    "backward": "forward",
}


def _mirror(text: str, way: str) -> str:
    """A direction phrase written for "left" / "up" / "forward", said for its opposite."""
    swaps = {
        "left": (("left", "right"),),
        "up": (
            ("upward", "downward"),
            ("up", "down"),
            ("higher", "lower"),
            ("ceiling", "floor"),
            ("sky", "ground"),
        ),
    }
    for old, new in swaps.get(way, ()):
        text = text.replace(old, new)
    return text


# ---- directions, per way: the phrases a step verb takes ----------------------------------------

STEP_WAYS: dict[str, list[str]] = {
    "left": [
        "left",
        "to the left",
        "leftward",
        "leftwards",
        "toward the left",
        "towards the left",
        "to its left",
        "over to the left",
        "off to the left",
        "to the left side",
        "to the left-hand side",
        "in a leftward direction",
        "a little to the left",
        "slightly left",
        "a bit to the left",
        "further left",
        "farther to the left",
        "more to the left",
        "to the camera's left",
        "to the photographer's left",
        "a few steps to the left",
        "about half a metre to the left",
        "sideways to the left",
        "laterally to the left",
        "a short distance to the left",
    ],
    "up": [
        "up",
        "upward",
        "upwards",
        "higher",
        "up a bit",
        "a little higher",
        "further up",
        "vertically upward",
        "straight up",
        "to a higher position",
        "to a higher spot",
        "a few centimetres up",
        "up by about 20 cm",
    ],
    "forward": [
        "forward",
        "forwards",
        "ahead",
        "straight ahead",
        "closer",
        "nearer",
        "closer to the scene",
        "toward the scene",
        "towards the subject",
        "further in",
        "into the scene",
        "in the direction it was facing",
        "along its line of sight",
        "a few steps forward",
        "nearer to the subject",
        "a little closer",
    ],
    "backward": [
        "back",
        "backward",
        "backwards",
        "farther back",
        "further back",
        "away",
        "away from the scene",
        "farther away",
        "further from the subject",
        "back a bit",
        "a few steps back",
        "opposite to the direction it was facing",
        "against its viewing direction",
        "a little farther away",
    ],
}
STEP_WAYS["right"] = [_mirror(t, "left") for t in STEP_WAYS["left"]]
STEP_WAYS["down"] = [_mirror(t, "up") for t in STEP_WAYS["up"]]

# Verbs of a step on any axis; and those said only sideways (a sidestep, a strafe).
STEP_VERBS: tuple[str, ...] = (
    "moved",
    "shifted",
    "slid",
    "stepped",
    "walked",
    "drifted",
    "travelled",
    "traveled",
    "went",
    "headed",
    "edged",
    "inched",
    "scooted",
    "glided",
    "was moved",
    "was shifted",
    "was carried",
    "was displaced",
    "was translated",
    "translated",
    "has moved",
    "had moved",
    "has been moved",
    "moves",
    "got moved",
    "relocated",
    "was repositioned",
    "was slid",
)
SIDEWAYS_VERBS = ("sidestepped", "strafed", "trucked", "crabbed", "sidled", "shuffled")

SUBJECTS = (
    "",
    "It ",
    "The camera ",
    "The photographer ",
    "The shooter ",
    "The operator ",
    "The camera position ",
)


def _step_rows() -> list[tuple[str, str]]:
    rows = []
    for way, phrases in STEP_WAYS.items():
        verbs = STEP_VERBS + (SIDEWAYS_VERBS if way in ("left", "right") else ())
        for verb, direction in itertools.product(verbs, phrases):
            rows.append((f"{verb} {direction}", f"T {way}"))
    return rows


# Verbs (and fixed phrases) that carry their own way.
CARRYING: dict[str, tuple[str, ...]] = {
    "up": (
        "rose",
        "climbed",
        "ascended",
        "was raised",
        "was lifted",
        "was elevated",
        "was hoisted",
        "gained height",
        "got higher",
        "went higher",
        "moved higher",
        "rose up",
        "was lifted up",
        "pedestalled up",
        "boomed up",
    ),
    "down": (
        "sank",
        "descended",
        "dropped",
        "was lowered",
        "fell",
        "crouched",
        "squatted",
        "lost height",
        "got lower",
        "went lower",
        "moved lower",
        "dropped down",
        "sank lower",
        "pedestalled down",
        "stooped",
    ),
    "forward": (
        "advanced",
        "approached",
        "approached the scene",
        "closed in",
        "came closer",
        "got closer",
        "drew nearer",
        "pushed in",
        "dollied in",
        "proceeded",
        "proceeded forward",
        "moved in closer",
        "stepped in",
        "crept closer",
        "closed the distance to the subject",
    ),
    "backward": (
        "retreated",
        "withdrew",
        "receded",
        "backed up",
        "backed off",
        "backed away",
        "pulled back",
        "pulled out",
        "dollied out",
        "drew back",
        "fell back",
        "stepped back",
        "stepped away",
        "moved away",
        "increased its distance from the scene",
    ),
}

STEP_NOUNS: dict[str, tuple[str, ...]] = {
    "left": (
        "A move to the left",
        "A shift to the left",
        "A step to the left",
        "A slide to the left",
        "A leftward move",
        "Leftward movement",
        "Leftward translation",
        "Translation to the left",
        "A translation toward the left",
        "Lateral movement to the left",
        "A sideways step to the left",
        "Displacement to the left",
        "A leftward displacement",
        "A leftward step",
        "Truck left",
        "A truck to the left",
    ),
    "up": (
        "An upward move",
        "Upward translation",
        "A rise",
        "A climb",
        "An ascent",
        "An upward shift",
        "A move upward",
        "Vertical movement upward",
        "A gain in height",
        "Upward displacement",
    ),
    "forward": (
        "A forward move",
        "Forward translation",
        "An advance",
        "An approach",
        "A step forward",
        "A step closer",
        "Forward movement",
        "A move toward the scene",
        "A push in",
        "Dolly in",
    ),
    "backward": (
        "A backward move",
        "Backward translation",
        "A retreat",
        "A step back",
        "Backward movement",
        "A move away from the scene",
        "A pull back",
        "Dolly out",
    ),
}


def _mirror_noun(text: str, way: str) -> str:
    """A noun phrase written for "left" / "up", said for the opposite way (the case kept)."""
    if way == "left":
        return text.replace("left", "right").replace("Left", "Right")
    swaps = (("upward", "downward"), ("Upward", "Downward"), ("rise", "descent"), ("climb", "drop"))
    swaps += (("ascent", "descent"), ("gain in height", "loss of height"))
    for old, new in swaps:
        if old in text:
            return text.replace(old, new)
    return text.replace("up", "down")


for _way in ("left", "up"):
    STEP_NOUNS[OPPOSITE[_way]] = tuple(_mirror_noun(t, _way) for t in STEP_NOUNS[_way])

# Hedges and frame notes: neither changes the claim.
HEDGES = (
    "{}",
    "It seems to have {}",
    "It appears to have {}",
    "The camera seems to have {}",
    "It seemed to have {}",
    "It probably {}",
    "Apparently it {}",
    "Most likely it {}",
    "It looks like it {}",
    "It looks as if the camera {}",
    "Perhaps it {}",
    "It evidently {}",
)
NOTES = (
    "",
    " (in the first image's frame)",
    ", from the photographer's point of view",
    ", as seen from behind the camera",
    ", relative to where it started",
    ", compared with before",
    " between the two shots",
    " from one photo to the next",
    ", judging by the two pictures",
    ", relative to the first shot",
    " since the first photo",
)


def _hedged_rows() -> list[tuple[str, str]]:
    """A few claims (past form, participle) under every hedge and note."""
    rows = []
    samples = [
        ("moved to the left", "moved to the left", "T left"),
        ("shifted upward", "shifted upward", "T up"),
        ("stepped back", "stepped back", "T backward"),
        ("rose", "risen", "T up"),
        ("advanced", "advanced", "T forward"),
        ("turned to the right", "turned to the right", "R yaw right"),
        ("tilted downward", "tilted downward", "R pitch down"),
        ("rolled clockwise", "rolled clockwise", "R roll clockwise"),
        ("stayed still", "stayed still", "S"),
    ]
    for (past, participle, claim), hedge, note in itertools.product(samples, HEDGES, NOTES):
        verb = participle if "to have" in hedge else past
        text = hedge.format(verb) + note
        rows.append((text[:1].upper() + text[1:], claim))
    return rows


def _carrying_rows() -> list[tuple[str, str]]:
    rows = []
    for way, verbs in CARRYING.items():
        for verb, subject in itertools.product(verbs, SUBJECTS[:5]):
            rows.append((f"{subject}{verb}", f"T {way}"))
    return rows


# ---- rotations ------------------------------------------------------------------------------

TURN_VERBS = (
    "turned",
    "rotated",
    "panned",
    "yawed",
    "swung",
    "swiveled",
    "swivelled",
    "pivoted",
    "veered",
    "was turned",
    "was panned",
    "was rotated",
    "was swung",
    "swung its view",
    "turned its view",
    "turned its head",
    "has turned",
    "had panned",
)
LOOK_VERBS = (
    "looked",
    "faced",
    "pointed",
    "aimed",
    "now faces",
    "now points",
    "ended up facing",
    "was aimed",
)
YAW_WAYS = (
    "left",
    "to the left",
    "leftward",
    "toward the left",
    "to its left",
    "a bit to the left",
    "slightly left",
    "about 20 degrees to the left",
    "roughly 15° to the left",
)
LOOK_WAYS = ("more to the left", "further left", "farther to the left", "further to the left")
YAW_NOUNS = (
    "A turn to the left",
    "A left turn",
    "A leftward turn",
    "A pan to the left",
    "A leftward pan",
    "Pan left",
    "Yaw left",
    "A yaw to the left",
    "Leftward rotation",
    "A rotation to the left",
    "A swivel to the left",
    "Its heading swung to the left",
    "Its line of sight swung left",
    "The viewing direction turned left",
    "Its gaze moved left",
    "Its aim shifted to the left",
    "The camera's heading changed to the left",
)

PITCH_VERBS = (
    "tilted",
    "pitched",
    "nodded",
    "angled",
    "tipped",
    "looked",
    "pointed",
    "aimed",
    "turned",
    "rotated",
    "was tilted",
    "was angled",
    "was pointed",
    "was tipped",
    "tilted its view",
)
PITCH_WAYS = (
    "up",
    "upward",
    "upwards",
    "a bit up",
    "slightly upward",
    "toward the ceiling",
    "toward the sky",
)
PITCH_NOUNS = (
    "A tilt up",
    "An upward tilt",
    "Tilt up",
    "Pitch up",
    "An upward pitch",
    "A nod upward",
    "Its aim rose",
    "Its view tilted up",
    "Its line of sight rose",
    "Its nose went up",
    "Its viewing direction rose",
    "It now points higher",
    "It ended up looking more upward",
)

ROLL_VERBS = (
    "rolled",
    "rotated",
    "spun",
    "twisted",
    "canted",
    "banked",
    "turned",
    "was rolled",
    "was rotated",
)
ROLL_SENSES = {
    "clockwise": ("clockwise", "CW"),
    "counterclockwise": ("counterclockwise", "counter-clockwise", "anticlockwise", "anti-clockwise", "CCW"),
}
ROLL_AXES = (
    "",
    " about the lens axis",
    " around the optical axis",
    " about its viewing axis",
    " around its line of sight",
    " in the image plane",
    " around the lens",
)
ROLL_NOUNS = (
    "A {} roll",
    "{} roll",
    "A roll {}",
    "A {} rotation about the optical axis",
    "A {} twist",
    "A {} cant",
    "{}, about the lens axis",
    "A {} in-plane rotation",
    "A {} dutch tilt",
    "A {} spin around the lens",
)


def _flip_left(text: str) -> str:
    return text.replace("left", "right").replace("Left", "Right")


def _yaw_rows() -> list[tuple[str, str]]:
    rows = []
    for verb, way in itertools.product(TURN_VERBS, YAW_WAYS):
        rows.append((f"It {verb} {way}", "R yaw left"))
        rows.append((f"The camera {_flip_left(verb)} {_flip_left(way)}", "R yaw right"))
    for verb, way in itertools.product(LOOK_VERBS, LOOK_WAYS + YAW_WAYS[:2]):
        rows.append((f"It {verb} {way}", "R yaw left"))
        rows.append((f"It {verb} {_flip_left(way)}", "R yaw right"))
    for noun in YAW_NOUNS:
        rows += [(noun, "R yaw left"), (_flip_left(noun), "R yaw right")]
    rows += [
        ("It turned clockwise as seen from above", "R yaw right"),
        ("Rotated counterclockwise, viewed from above", "R yaw left"),
    ]
    return rows


def _pitch_rows() -> list[tuple[str, str]]:
    rows = []
    for verb, way in itertools.product(PITCH_VERBS, PITCH_WAYS):
        rows.append((f"It {verb} {way}", "R pitch up"))
        rows.append((f"The camera {verb} {_mirror(way, 'up')}", "R pitch down"))
    for noun in PITCH_NOUNS:
        rows.append((noun, "R pitch up"))
    rows += [
        ("A tilt down", "R pitch down"),
        ("A downward tilt", "R pitch down"),
        ("Tilt down", "R pitch down"),
        ("Pitch down", "R pitch down"),
        ("Its aim dropped", "R pitch down"),
        ("Its view tilted down", "R pitch down"),
        ("Its line of sight dropped", "R pitch down"),
        ("Its nose went down", "R pitch down"),
        ("It now points lower", "R pitch down"),
        ("It ended up looking more downward", "R pitch down"),
        ("It looked toward the floor", "R pitch down"),
    ]
    return rows


def _roll_rows() -> list[tuple[str, str]]:
    rows = []
    for sense, words in ROLL_SENSES.items():
        for verb, word, axis in itertools.product(ROLL_VERBS, words, ROLL_AXES):
            if verb in ("turned", "rotated", "was rotated") and not axis and word in ("CW", "CCW"):
                continue  # "turned CW" alone: kept to the spelled-out senses
            rows.append((f"It {verb} {word}{axis}", f"R roll {sense}"))
        for noun, word in itertools.product(ROLL_NOUNS, words[:3]):
            text = noun.format(word)
            rows.append((text[:1].upper() + text[1:], f"R roll {sense}"))
    return rows


# ---- the second camera's place -----------------------------------------------------------------

POSITION_PHRASES: dict[str, tuple[str, ...]] = {
    "left": (
        "To the left of the first camera",
        "To the left of the first one",
        "Left of the first camera",
        "On the left of the first camera",
        "On the left side of the first camera",
        "To the first camera's left",
        "On its left",
        "To its left",
        "Left of it",
        "On the left",
        "The second camera is to the left of the first",
        "The second camera sits to the left",
        "The second camera was placed to the left",
        "It was taken from further left",
        "It was taken from a spot to the left",
        "It was shot from a point further left",
        "It stands to the left",
        "The second shot was taken from further left",
        "The later photo was taken from a position to the left",
        "The camera for the second shot was to the left",
        "Located to the left",
        "Positioned to the left of the first camera",
    ),
    "up": (
        "Above the first camera",
        "Higher than the first camera",
        "Above it",
        "Higher up",
        "At a greater height",
        "The second camera is above the first",
        "It was taken from higher up",
        "It was shot from a higher spot",
        "From a higher vantage point",
        "The second shot was taken from a higher position",
        "Located above",
        "Positioned higher than the first camera",
    ),
    "forward": (
        "In front of the first camera",
        "Ahead of the first camera",
        "In front of it",
        "Ahead of it",
        "Further forward",
        "The second camera is in front of the first",
        "It was taken from closer in",
        "It was shot from a point further forward",
        "The second shot was taken from closer to the scene",
        "Located in front",
        "Positioned ahead of the first camera",
    ),
    "backward": (
        "Behind the first camera",
        "Behind it",
        "Further back",
        "Farther back",
        "The second camera is behind the first",
        "It was taken from further back",
        "It was shot from farther back",
        "The second shot was taken from farther away",
        "Located behind",
        "Positioned behind the first camera",
    ),
}


def _position_mirror(text: str, way: str) -> str:
    if way == "left":
        return text.replace("left", "right").replace("Left", "Right")
    swaps = (("Above", "Below"), ("above", "below"), ("Higher up", "Lower down"), ("higher up", "lower down"))
    swaps += (("Higher", "Lower"), ("higher", "lower"), ("greater height", "lesser height"))
    for old, new in swaps:
        text = text.replace(old, new)
    return text


POSITION_PHRASES["right"] = tuple(_position_mirror(t, "left") for t in POSITION_PHRASES["left"])
POSITION_PHRASES["down"] = tuple(_position_mirror(t, "up") for t in POSITION_PHRASES["up"])


def _position_rows() -> list[tuple[str, str]]:
    return [(text, f"P {way}") for way, texts in POSITION_PHRASES.items() for text in texts]


# ---- stillness -------------------------------------------------------------------------------

STILL_PHRASES = (
    "It stayed still",
    "It did not move",
    "It didn't move at all",
    "No movement",
    "No motion",
    "It stayed put",
    "Stayed in the same place",
    "It remained stationary",
    "It was not moved",
    "It held still",
    "Nothing changed",
    "The camera stayed where it was",
    "Same position, same direction",
    "Unchanged",
    "No change",
    "It kept still",
    "It didn't budge",
    "It stood still",
    "Both photos were taken from the same spot with the same aim",
    "It neither moved nor rotated",
    "No translation or rotation",
    "Stationary",
    "Motionless",
    "It remained where it was",
    "It stayed in one place",
    "It never moved",
    "It was kept in place",
    "The camera did not move or turn",
    "The camera held still between the two shots",
    "No camera motion at all",
)


# ---- near-misses: no camera claim, or not one that can be read without a guess -------------------

MUST_STAY_UNREAD = (
    # something else moved
    "The chair moved left",
    "The person walked to the right",
    "The car drove forward",
    "The scene shifted left",
    "Objects moved to the right in the frame",
    "The building moved up in the frame",
    "The background slid left",
    "The scene rotated clockwise",
    "The image turned clockwise",
    "The horizon tilted clockwise",
    "Everything in view shifted to the right",
    # ... also under a hedge, which opens a clause with its own subject
    "It looks like the scene moved left",
    "It seems the scene moved left",
    "The scene appears to have shifted left",
    "It panned left and the scene appears to have shifted right",
    "It panned left and the scene apparently slid right",
    "It looks as if the objects shifted right",
    "Apparently the background slid left",
    "It looks like the view shifted left",
    # the focal length, not the camera
    "It zoomed in",
    "It zoomed out",
    "The lens zoomed in",
    "A zoom in",
    # negated: what did not happen
    "It did not turn left",
    "It didn't move left",
    "Not to the left",
    "It did not tilt up",
    "It was not raised",
    # two ways at once, or none
    "It moved left or right",
    "Either up or down",
    "It turned left or right",
    "Back and forth",
    "It moved",
    "It turned",
    "It looked around",
    "It returned to where it started",
    "It went back to its first position",
)


# The step rows are said with every subject (`_with_subject`); the others as written.
OTHER_ROWS = (
    _carrying_rows()
    + [(noun, f"T {way}") for way, nouns in STEP_NOUNS.items() for noun in nouns]
    + _hedged_rows()
    + _yaw_rows()
    + _pitch_rows()
    + _roll_rows()
    + _position_rows()
    + [(text, "S") for text in STILL_PHRASES]
)


def _with_subject(rows: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """The step rows with every subject: the claim does not depend on who is said to move."""
    out = []
    for (text, claim), subject in itertools.product(rows, SUBJECTS):
        phrase = f"{subject}{text}"
        out.append((phrase[:1].upper() + phrase[1:], claim))
    return out


def _geometry(claim: str) -> str:
    """A step and a place are one geometry (the second camera's centre in the first's frame)."""
    return "T" + claim[1:] if claim.startswith("P ") else claim


_POSITION_ASK = "Where was image 2 taken from, relative to image 1?\nA. "


def _read(text: str, claim: str) -> str:
    """The claim an option states; a place is read as an option of a position question, where a
    bare direction ("To its left") takes the kind the stem asks."""
    if claim.startswith("P "):
        return short(read_question(f"{_POSITION_ASK}{text}\nB. Somewhere else", 2).options["A"])
    return short(read_phrase(text))


def test_every_development_option_reads_as_its_construction_says() -> None:
    rows = _with_subject(_step_rows()) + OTHER_ROWS
    wrong = [(text, want, _read(text, want)) for text, want in rows]
    wrong = [(text, want, got) for text, want, got in wrong if _geometry(got) != _geometry(want)]
    assert not wrong, f"{len(wrong)} of {len(rows)} misread:\n" + "\n".join(map(str, wrong[:40]))


@pytest.mark.parametrize("text", MUST_STAY_UNREAD)
def test_near_misses_stay_unread(text: str) -> None:
    assert short(read_phrase(text)).startswith("U"), read_phrase(text)


# ---- a second sweep: places, steps, turns and stillness in plainer and rarer words ----------------

# (P: read as an option of a position question), expected claim
SECOND_SWEEP: list[tuple[str, str]] = [
    ("On the left side of the first camera", "P left"),
    ("Further to the left than camera one", "P left"),
    ("The second camera sits on the left", "P left"),
    ("Leftward of the first camera", "P left"),
    ("At the left of the original viewpoint", "P left"),
    ("Left-hand side", "P left"),
    ("In a spot to the left", "P left"),
    ("It was placed to the left", "P left"),
    ("The left side", "P left"),
    ("On the left-hand side relative to it", "P left"),
    ("More leftward", "P left"),
    ("Higher up than the reference", "P up"),
    ("Lower than the reference camera", "P down"),
    ("Nearer the scene than the reference", "P forward"),
    ("Closer to the subject than the first camera", "P forward"),
    ("Further from the subject than the first camera", "P backward"),
    ("Beneath it", "P down"),
    ("At a higher point", "P up"),
    ("At a lower point", "P down"),
    ("Closer in", "P forward"),
    ("Further out", "P backward"),
    ("Up above it", "P up"),
    ("Down below it", "P down"),
    ("In front of the reference camera", "P forward"),
    ("Back behind it", "P backward"),
    ("To the rear of it", "P backward"),
    ("To the rear", "P backward"),
    ("At its rear", "P backward"),
    ("On its right-hand side", "P right"),
    ("Right-hand side of the first camera", "P right"),
    ("Elevated relative to the first camera", "P up"),
    ("Raised above the first camera", "P up"),
    ("Lowered relative to the first camera", "P down"),
    ("Nearer to the subject", "P forward"),
    ("Deeper into the scene", "P forward"),
    ("Further from the scene", "P backward"),
    ("Located more to the left", "P left"),
    ("Placed higher", "P up"),
    ("Sitting lower", "P down"),
    ("Standing further back", "P backward"),
    ("Standing closer", "P forward"),
    ("It lies to the left", "P left"),
    ("It lies above", "P up"),
    ("Its location is to the left", "P left"),
    ("Its position is higher", "P up"),
    ("Its position is further forward", "P forward"),
    ("The camera is closer to the scene", "P forward"),
    ("The camera is further from the scene", "P backward"),
    ("Over on the left", "P left"),
    ("Up higher", "P up"),
    ("Down lower", "P down"),
    ("Out in front of it", "P forward"),
    ("Set back from it", "P backward"),
    ("Set further back", "P backward"),
    ("Ahead of the first shot's camera", "P forward"),
    ("Left of the first shot's camera", "P left"),
    ("To the left from the first camera's view", "P left"),
    ("Left, as seen by the first camera", "P left"),
    ("On the first camera's left", "P left"),
    ("Above the first camera's position", "P up"),
    ("It went leftward", "T left"),
    ("It moved over to the left", "T left"),
    ("It shifted over left", "T left"),
    ("It moved laterally left", "T left"),
    ("It traveled sideways left", "T left"),
    ("It scooted over to the right", "T right"),
    ("Leftward", "B left"),
    ("It was translated leftward", "T left"),
    ("A lateral translation to the left", "T left"),
    ("Camera translated left", "T left"),
    ("Translated to the left", "T left"),
    ("It moved in the left direction", "T left"),
    ("Movement to the left", "T left"),
    ("Motion to the left", "T left"),
    ("Leftwards motion", "T left"),
    ("It moved horizontally to the left", "T left"),
    ("It went up a bit", "T up"),
    ("It went higher", "T up"),
    ("It climbed higher", "T up"),
    ("It moved vertically upward", "T up"),
    ("It was raised up", "T up"),
    ("It moved up vertically", "T up"),
    ("Vertical rise", "T up"),
    ("It gained some height", "T up"),
    ("It went down a bit", "T down"),
    ("It moved vertically downward", "T down"),
    ("Vertical drop", "T down"),
    ("It went lower", "T down"),
    ("It was brought lower", "T down"),
    ("It lowered itself", "T down"),
    ("It moved lower down", "T down"),
    ("It got closer to the scene", "T forward"),
    ("It moved in toward the scene", "T forward"),
    ("It went forward", "T forward"),
    ("It walked ahead", "T forward"),
    ("It moved straight ahead", "T forward"),
    ("It moved toward the subject", "T forward"),
    ("It got nearer to the subject", "T forward"),
    ("It drew closer", "T forward"),
    ("It went backward", "T backward"),
    ("It went back", "T backward"),
    ("It moved away from the subject", "T backward"),
    ("It got farther from the scene", "T backward"),
    ("It backed out", "T backward"),
    ("It retreated backward", "T backward"),
    ("It moved to the rear", "T backward"),
    ("It walked backwards", "T backward"),
    ("It reversed", "T backward"),
    ("It went in reverse", "T backward"),
    ("It travelled rearward", "T backward"),
    ("It stepped rearward", "T backward"),
    ("It moved toward the back", "T backward"),
    ("It turned to its left", "R yaw left"),
    ("It rotated leftward", "R yaw left"),
    ("It swung round to the left", "R yaw left"),
    ("It panned to the left side", "R yaw left"),
    ("It yawed toward the left", "R yaw left"),
    ("The camera was rotated to the left", "R yaw left"),
    ("Turned left on the spot", "R yaw left"),
    ("Rotated left in place", "R yaw left"),
    ("It turned left around its vertical axis", "R yaw left"),
    ("Its view swung to the left", "R yaw left"),
    ("It looked more to the left", "R yaw left"),
    ("It faced further left", "R yaw left"),
    ("It aimed further left", "R yaw left"),
    ("Its aim swung left", "R yaw left"),
    ("Its direction swung left", "R yaw left"),
    ("The lens turned to the left", "R yaw left"),
    ("The lens swung left", "R yaw left"),
    ("It pointed more upward", "R pitch up"),
    ("It aimed higher", "R pitch up"),
    ("It looked higher", "R pitch up"),
    ("It tilted its lens up", "R pitch up"),
    ("It pitched its view up", "R pitch up"),
    ("It tipped upward", "R pitch up"),
    ("It angled upward", "R pitch up"),
    ("The camera's aim went up", "R pitch up"),
    ("Its gaze lifted", "R pitch up"),
    ("It looked upward more", "R pitch up"),
    ("It nodded downward", "R pitch down"),
    ("It tipped its nose down", "R pitch down"),
    ("It pointed lower", "R pitch down"),
    ("It rolled clockwise around the lens", "R roll clockwise"),
    ("It rotated around the lens axis clockwise", "R roll clockwise"),
    ("A clockwise rotation around the line of sight", "R roll clockwise"),
    ("It twisted clockwise about its optical axis", "R roll clockwise"),
    ("It spun clockwise on its axis", "R roll clockwise"),
    ("It rolled counterclockwise along the viewing axis", "R roll counterclockwise"),
    ("It rotated counterclockwise in the frame plane", "R roll counterclockwise"),
    ("Rotated anticlockwise around the optical axis", "R roll counterclockwise"),
    ("A counter-clockwise spin about the lens", "R roll counterclockwise"),
    ("It turned clockwise around its optical axis", "R roll clockwise"),
    ("It did not change position or direction", "S"),
    ("It stayed exactly where it was", "S"),
    ("No change in position or orientation", "S"),
    ("The same pose", "S"),
    ("Identical pose", "S"),
    ("It kept the same position and direction", "S"),
    ("The camera remained fixed", "S"),
    ("It remained fixed", "S"),
    ("It held steady", "S"),
    ("It stayed steady", "S"),
    ("It didn't move or turn", "S"),
    ("It neither moved nor turned", "S"),
    ("Same spot, same heading", "S"),
    ("No shift, no turn", "S"),
    ("Nothing moved", "S"),
    ("It stayed put and kept its aim", "S"),
    ("The pose did not change", "S"),
    ("Same place, same angle", "S"),
    ("It remained in the same place facing the same way", "S"),
    ("It was not moved or rotated", "S"),
    ("Fixed in place", "S"),
    ("Stayed fixed", "S"),
    ("Unmoved and unrotated", "S"),
    ("It remained motionless", "S"),
    ("It stood still", "S"),
    ("Perfectly still", "S"),
    ("Completely stationary", "S"),
    ("It did not move at all", "S"),
]
# Said in words that leave the claim open: a view that rose (a tilt or a step), a camera that "rolled"
# toward a side (a roll, or rolling along on wheels), the horizon (the picture's content), sideways
# with no side.
SECOND_SWEEP_UNREAD = [
    "It slid sideways",
    "Its view rose",
    "It rolled right",
    "It banked to the left",
    "Its horizon rotated clockwise",
    "A roll to the left",
]


@pytest.mark.parametrize(("text", "claim"), SECOND_SWEEP)
def test_second_sweep_reads_as_written(text: str, claim: str) -> None:
    assert _geometry(_read(text, claim)) == _geometry(claim)


@pytest.mark.parametrize("text", SECOND_SWEEP_UNREAD)
def test_second_sweep_open_wordings_stay_unread(text: str) -> None:
    assert short(read_phrase(text)).startswith("U")


# ---- a third sweep: operator jargon, comparatives, magnitudes, and notes on the frame -------------

THIRD_SWEEP: list[tuple[str, str]] = [
    ("Boom up", "T up"),
    ("Pedestal down", "T down"),
    ("Tilt up", "R pitch up"),
    ("Pan right", "R yaw right"),
    ("Truck left", "T left"),
    ("Dolly in", "T forward"),
    ("Dolly back", "T backward"),
    ("Track right", "T right"),
    ("Ped up", "T up"),
    ("It's further left than before", "B left"),
    ("It is more to the left than in image 1", "B left"),
    ("Further right than in the first shot", "B right"),
    ("Higher than in the first picture", "B up"),
    ("Lower than it was", "B down"),
    ("Closer than before", "T forward"),
    ("Farther away than before", "T backward"),
    ("It moved left (in the first image's frame)", "T left"),
    ("It moved left, in image 1's coordinates", "T left"),
    ("Left, from the shooter's side", "B left"),
    ("Moved left from the photographer's standpoint", "T left"),
    ("It moved to the photographer's left", "T left"),
    ("It shifted to the viewer's right", "T right"),
    ("It went left (as seen through the viewfinder)", "T left"),
    ("It turned left, judged from behind the camera", "R yaw left"),
    ("It rolled clockwise (seen from behind the camera)", "R roll clockwise"),
    ("It rolled clockwise, as the photographer sees it", "R roll clockwise"),
    ("It rotated clockwise from the shooter's view", "R roll clockwise"),
    ("Clockwise, looking through the lens", "R roll clockwise"),
    ("It moved left by about a metre", "T left"),
    ("It moved 30 cm to the left", "T left"),
    ("It turned about 15 degrees left", "R yaw left"),
    ("A 10° pan to the right", "R yaw right"),
    ("A slight leftward translation", "T left"),
    ("A small step up", "T up"),
    ("A big step back", "T backward"),
    ("Moved a touch to the left", "T left"),
    ("Nudged a bit to the left", "T left"),
    ("A tad higher", "B up"),
    ("A hair to the right", "B right"),
    ("Just slightly lower", "B down"),
    ("Marginally further forward", "B forward"),
    ("Way off to the left", "B left"),
    ("Considerably higher", "B up"),
    ("It turned leftwards by a few degrees", "R yaw left"),
    ("It tilted its gaze upward", "R pitch up"),
    ("It raised its aim", "R pitch up"),
    ("It lowered its aim", "R pitch down"),
    ("It pointed its lens downward", "R pitch down"),
    ("It angled the lens up", "R pitch up"),
    ("It pitched the camera down", "R pitch down"),
    ("It tipped clockwise", "R roll clockwise"),
    ("It rotated the frame clockwise", "R roll clockwise"),
    ("It spun the camera clockwise on its lens axis", "R roll clockwise"),
]
# Jargon of a combined or unclear move (an arc, a jib), compass and ship words, a view raised (a tilt
# or a step), a lean or a head cocked (a roll with no sense), the frame or photo as what rotated.
THIRD_SWEEP_UNREAD = [
    "Arc left",
    "Jib up",
    "The camera yawed 20 degrees to port",
    "It moved port side",
    "It headed west",
    "It raised its view",
    "It dipped its view",
    "It cocked its head to the left",
    "It leaned to the left",
    "The frame rotated clockwise",
    "The photo is rotated clockwise",
]


@pytest.mark.parametrize(("text", "claim"), THIRD_SWEEP)
def test_third_sweep_reads_as_written(text: str, claim: str) -> None:
    assert short(read_phrase(text)) == claim


@pytest.mark.parametrize("text", THIRD_SWEEP_UNREAD)
def test_third_sweep_open_wordings_stay_unread(text: str) -> None:
    assert short(read_phrase(text)).startswith("U")
