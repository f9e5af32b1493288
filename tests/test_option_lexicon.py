"""Options read by meaning: a table of option wordings written for this file (not taken from the
paraphrase corpus), each with the claim it states, across every kind and sense of camera motion and
position, plus near-misses that must stay unread.

Expected claims are written in a short form: ``T left`` (a translation; several ways for a diagonal),
``P up`` (a position), ``R yaw left`` / ``R pitch up`` / ``R roll clockwise`` (a rotation), ``S``
(still), ``B left`` (a bare direction: its kind is the one the question asks), ``C <part> + <part>``
(a compound), ``U`` (unread) and ``U2`` (unread because it says two things at once).
"""

from __future__ import annotations

import random
from collections import Counter

import pytest

from bench.paraphrase_reading import option_outcomes
from shared.questions.claims import (
    Bare,
    Claim,
    Compound,
    Position,
    Rotation,
    Still,
    Translation,
    Unread,
)
from shared.questions.lexicon import read_phrase
from shared.questions.reading import read_question
from tests.support.option_wordings import OPTION_WORDINGS
from tests.support.paraphrases import load_wordings, phrase, random_spec

_WAY_ORDER = ("forward", "backward", "up", "down", "left", "right")


def _ways(ways: tuple[str, ...]) -> str:
    return " ".join(sorted(ways, key=_WAY_ORDER.index))


def short(claim: Claim) -> str:
    """A claim in the table's short form."""
    if isinstance(claim, Translation):
        return f"T {_ways(claim.ways)}"
    if isinstance(claim, Position):
        return f"P {_ways(claim.ways)}"
    if isinstance(claim, Bare):
        return f"B {_ways(claim.ways)}"
    if isinstance(claim, Rotation):
        return f"R {claim.axis} {claim.sense}"
    if isinstance(claim, Still):
        return "S"
    if isinstance(claim, Compound):
        return "C " + " + ".join(sorted(short(part) for part in claim.parts))
    if isinstance(claim, Unread):
        return "U2" if claim.two_claims else "U"
    return claim.kind


TRANSLATIONS = [
    # sideways
    ("The camera shifted to the left", "T left"),
    ("It slides right", "T right"),
    ("Sliding leftward", "T left"),
    ("It sidestepped right", "T right"),
    ("Strafed to the left", "T left"),
    ("Trucked right", "T right"),
    ("The camera tracked left", "T left"),
    ("It crabbed to the right", "T right"),
    ("Walked a few steps to the left", "T left"),
    ("It drifted rightward", "T right"),
    ("Traveled to the left", "T left"),
    ("Travelled right", "T right"),
    ("Moved further to the left", "T left"),
    ("It moved more to the right", "T right"),
    ("It ended up further left", "B left"),
    ("Its position shifted to the left", "T left"),
    ("The shooter stepped to their right", "T right"),
    ("Moved toward the left side of the frame", "T left"),
    ("A lateral move to the left", "T left"),
    ("Sideways, to the right", "T right"),
    ("It glided over to the right", "T right"),
    ("Moves left", "T left"),
    ("Moving rightwards", "T right"),
    # vertical
    ("The camera rose", "T up"),
    ("It rises", "T up"),
    ("Rising higher", "T up"),
    ("Climbing", "T up"),
    ("It climbed up", "T up"),
    ("Ascending", "T up"),
    ("It went up", "T up"),
    ("Moved upward", "T up"),
    ("It was elevated", "T up"),
    ("Lifted higher", "T up"),
    ("Pedestaled up", "T up"),
    ("Boomed up", "T up"),
    ("Gained height", "T up"),
    ("From a higher vantage point", "T up"),
    ("It sank", "T down"),
    ("Sinking lower", "T down"),
    ("Descending", "T down"),
    ("It dropped down", "T down"),
    ("It was lowered a bit", "T down"),
    ("Went down", "T down"),
    ("Moved downward", "T down"),
    ("Lost height", "T down"),
    ("At a lower elevation", "T down"),
    ("It came down", "T down"),
    ("It fell", "T down"),
    ("Crouched lower", "T down"),
    # toward and away from the scene
    ("Moved forward", "T forward"),
    ("It advanced", "T forward"),
    ("Advancing toward the scene", "T forward"),
    ("Proceeding ahead", "T forward"),
    ("It approached the scene", "T forward"),
    ("Approaching", "T forward"),
    ("Stepped closer", "T forward"),
    ("Came closer", "T forward"),
    ("Got nearer to the subject", "T forward"),
    ("Walked forward", "T forward"),
    ("It dollied in", "T forward"),
    ("Pushed in", "T forward"),
    ("Moved in closer", "T forward"),
    ("Stepped in", "T forward"),
    ("Moved toward the scene", "T forward"),
    ("Moved backward", "T backward"),
    ("Backed up", "T backward"),
    ("It backed off", "T backward"),
    ("Backing away", "T backward"),
    ("Stepped back", "T backward"),
    ("Withdrawing", "T backward"),
    ("It retreated", "T backward"),
    ("Pulled back", "T backward"),
    ("Pulled out", "T backward"),
    ("Dollied out", "T backward"),
    ("Moved away from the scene", "T backward"),
    ("Farther from the subject", "T backward"),
    ("Further away", "T backward"),
    ("Receded", "T backward"),
    ("Moved back", "T backward"),
    ("It went back", "T backward"),
    ("It moved in the direction it was facing", "T forward"),
    ("Moved opposite to the direction the camera was pointing", "T backward"),
    ("Moved along its line of sight", "T forward"),
    ("It moved to a greater height", "T up"),
    ("Height: up", "T up"),
    ("A higher position", "T up"),
    ("Its location is further left", "T left"),
    ("Its elevation rose", "T up"),
    ("Sidled to the right", "T right"),
    ("Scooted over left", "T left"),
    ("Shuffled to the right", "T right"),
    ("Knelt down", "T down"),
    ("It was moved forward", "T forward"),
    # diagonals
    ("Moved forward and to the left", "T forward left"),
    ("Stepped forward-left", "T forward left"),
    ("Went up and to the right", "T up right"),
]

ROTATIONS = [
    # yaw
    ("Turned to the left", "R yaw left"),
    ("It turns right", "R yaw right"),
    ("Turning leftward", "R yaw left"),
    ("Panned left", "R yaw left"),
    ("Panning to the right", "R yaw right"),
    ("Yawed left", "R yaw left"),
    ("Swiveled right", "R yaw right"),
    ("Swivelled to the left", "R yaw left"),
    ("Pivoted right", "R yaw right"),
    ("Veered to the left", "R yaw left"),
    ("Swung right", "R yaw right"),
    ("Swung its view to the left", "R yaw left"),
    ("Looked to the left", "R yaw left"),
    ("Glanced right", "R yaw right"),
    ("Its heading changed to the right", "R yaw right"),
    ("Pointed further left", "R yaw left"),
    ("Aimed more to the right", "R yaw right"),
    ("Faced left", "R yaw left"),
    ("Now faces more to the left", "R yaw left"),
    ("Rotated to the right", "R yaw right"),
    ("Rotated left about the vertical axis", "R yaw left"),
    ("Turned around", "R yaw around"),
    ("Did an about-face", "R yaw around"),
    ("Rotated clockwise as seen from above", "R yaw right"),
    ("It turned its head to the left", "R yaw left"),
    ("It rotated to face more to the right", "R yaw right"),
    # pitch
    ("Tilted up", "R pitch up"),
    ("Tilting downward", "R pitch down"),
    ("It tilts upward", "R pitch up"),
    ("Pitched up", "R pitch up"),
    ("Pitching down", "R pitch down"),
    ("Nodded down", "R pitch down"),
    ("Looked up", "R pitch up"),
    ("Looking downward", "R pitch down"),
    ("Looked down at the floor", "R pitch down"),
    ("Angled upward", "R pitch up"),
    ("Angled the camera down", "R pitch down"),
    ("Aimed higher", "R pitch up"),
    ("Pointed lower", "R pitch down"),
    ("Craned up", "R pitch up"),
    ("Tipped downward", "R pitch down"),
    ("Its view tilted up", "R pitch up"),
    ("Tilted toward the ceiling", "R pitch up"),
    ("Tilted toward the ground", "R pitch down"),
    ("Its line of sight dropped", "R pitch down"),
    ("Its aim went up", "R pitch up"),
    ("Tilted its lens upwards", "R pitch up"),
    ("Pointed the camera down", "R pitch down"),
    ("Turned its gaze upward", "R pitch up"),
    ("Nose down", "R pitch down"),
    ("Lowered its aim", "R pitch down"),
    ("Tilted to face the floor", "R pitch down"),
    ("It looked down more steeply", "R pitch down"),
    ("Rotated clockwise in the image plane", "R roll clockwise"),
    ("Rolled clockwise, as seen from behind the camera", "R roll clockwise"),
    ("Clockwise, looking through the lens", "R roll clockwise"),
    ("Swung its heading to the right", "R yaw right"),
    ("It was tilted down", "R pitch down"),
    ("Upward tilt movement", "R pitch up"),
    ("The camera's angle changed upward", "R pitch up"),
    ("Leftward yaw rotation", "R yaw left"),
    ("The direction of the camera changed to the right", "R yaw right"),
    ("Clockwise roll rotation", "R roll clockwise"),
    # roll
    ("Rolled clockwise", "R roll clockwise"),
    ("Rolling counterclockwise", "R roll counterclockwise"),
    ("Spun clockwise", "R roll clockwise"),
    ("Spinning anticlockwise", "R roll counterclockwise"),
    ("Canted counter-clockwise", "R roll counterclockwise"),
    ("Banked clockwise", "R roll clockwise"),
    ("Twisted anti-clockwise", "R roll counterclockwise"),
    ("Rotated clockwise around the optical axis", "R roll clockwise"),
    ("Rotated counterclockwise about its viewing axis", "R roll counterclockwise"),
    ("Turned clockwise about the line of sight", "R roll clockwise"),
    ("Clockwise", "R roll clockwise"),
    ("A clockwise roll", "R roll clockwise"),
    ("Rolled CW", "R roll clockwise"),
    ("Rolled 20 degrees clockwise", "R roll clockwise"),
    ("Rotated in the clockwise direction", "R roll clockwise"),
    ("Counter-clockwise around the lens", "R roll counterclockwise"),
    ("It rotated in a counterclockwise sense", "R roll counterclockwise"),
    # negated rotations: no turn about that axis
    ("Did not turn", "R yaw none"),
    ("Without tilting", "R pitch none"),
    ("No roll", "R roll none"),
]

STILL = [
    ("It stayed still", "S"),
    ("Stayed put", "S"),
    ("Remained stationary", "S"),
    ("Did not move", "S"),
    ("Didn't move at all", "S"),
    ("The camera did not budge", "S"),
    ("No movement", "S"),
    ("No change", "S"),
    ("Unchanged", "S"),
    ("Stationary", "S"),
    ("Held its position", "S"),
    ("Kept the same position", "S"),
    ("Stayed at the same spot", "S"),
    ("Stayed in the same place", "S"),
    ("Remained where it was", "S"),
    ("It was not moved", "S"),
    ("Same spot", "S"),
    ("Did not move or turn", "S"),
    ("Nothing changed", "S"),
    ("Motionless", "S"),
    ("Stood still", "S"),
    ("Its pose did not change", "S"),
    ("No displacement and no rotation", "S"),
    ("It stayed in its spot", "S"),
    ("Did not translate or rotate", "S"),
    ("There was no change in pose", "S"),
    ("Both position and orientation unchanged", "S"),
    ("Position unchanged", "S"),
    ("Its position and direction were unchanged", "S"),
    ("There was no visible movement", "S"),
    ("Stayed roughly where it was", "S"),
    ("Neither its position nor its orientation changed", "S"),
    ("Same position and orientation", "S"),
]

POSITIONS = [
    ("Above it", "B up"),
    ("To its left", "B left"),
    ("Behind the first camera", "B backward"),
    ("In front of the first camera", "B forward"),
    ("Ahead of it", "B forward"),
    ("To the shooter's left", "B left"),
    ("On the first camera's right", "B right"),
    ("Below and to the left", "B down left"),
    ("Lower than the first camera", "B down"),
    ("Higher than before", "B up"),
    ("Right behind it", "B backward"),
    ("Right above it", "B up"),
    ("Directly below it", "B down"),
    ("Located to the left", "P left"),
    ("Positioned above", "P up"),
    ("Situated behind the first", "P backward"),
    ("It was taken from a spot to the right", "P right"),
    ("Taken from higher up", "P up"),
    ("Shot from further left", "P left"),
    ("Further back", "T backward"),
    ("The second camera is positioned to the left of the first one", "P left"),
    ("Image 2's camera sits above image 1's", "P up"),
    ("Next to it on the left", "B left"),
    ("Slightly to the left and behind", "B backward left"),
    ("Higher up and further back", "T backward up"),
    ("The second shot was taken from a lower vantage point", "P down"),
    ("The second camera is to the left of the first", "B left"),
    ("The later photo was taken from further right", "P right"),
    ("Leftward", "B left"),
    ("Upward", "B up"),
]

COMPOUNDS = [
    ("Moved left and turned right", "C R yaw right + T left"),
    ("Rose while panning left", "C R yaw left + T up"),
    ("Stepped forward and tilted down", "C R pitch down + T forward"),
    ("Turned left, then moved forward", "C R yaw left + T forward"),
    ("Slid right as it rolled clockwise", "C R roll clockwise + T right"),
    ("Moved left without turning", "C R yaw none + T left"),
    ("It approached the scene, then turned left", "C R yaw left + T forward"),
    ("Moved to the right without rotating", "C R pitch none + R roll none + R yaw none + T right"),
    ("Turned leftwards by a small angle", "R yaw left"),
    ("Camera translated left and rotated right", "C R yaw right + T left"),
]

# Words that look like motion but say something else, or say two things, or too little: never read
# as a claim (a wrong claim can give a wrong answer; an unread one only stops it).
NEAR_MISSES = [
    # the scene moving in the frame is the camera's motion reversed: not read as the camera's
    ("The scene shifted to the left", "U"),
    ("Objects moved right in the frame", "U"),
    ("Everything in view slid left", "U"),
    ("The background drifted up", "U"),
    ("The image content moved down", "U"),
    ("The picture shifted right", "U"),
    ("The subject moved closer", "U"),
    ("It turned left so the scene moved right", "U"),
    ("It moved left, so objects shifted right", "U"),
    # the view moved, or was moved, by a step verb: a pan moves the view as much as a step does
    ("The view shifted to the left", "U"),
    ("Raised its view", "U"),
    ("Moved the framing to the right", "U"),
    # the first camera's place relative to the second is the reverse of what is asked
    ("The first camera is to the left of the second", "U"),
    ("The reference photo was taken higher", "U"),
    ("The position of the first camera is to the left", "U"),
    ("The first is to the left of the second", "U"),
    ("It is to the left of the second camera", "U"),
    # where a motion came from is the opposite of where it went
    ("It came in from the left", "U"),
    ("Approached from the right", "U"),
    # a zoom changes the focal length, not where the camera is
    ("It zoomed in", "U"),
    ("Zoomed out", "U"),
    # a return to a place is no direction of its own
    ("Went back to the first position", "U"),
    ("Came back", "U"),
    ("The camera moved to the left, then turned back", "U"),
    # "ended up" and "turned out" are idioms, not an upward step or a turn outward
    ("It turned out fine", "U"),
    ("Looked the same", "U"),
    ("It left the room", "U"),
    # too little said
    ("Turned", "U"),
    ("Moved", "U"),
    ("Sideways", "U"),
    ("Dipped", "U"),
    ("Next to it", "U"),
    ("Beside it", "U"),
    ("Slightly", "U"),
    ("Cannot be determined", "U"),
    ("Upside down", "U"),
    # a direction that does not fit its verb's axis
    ("Tilted left", "U"),
    ("Rolled right", "U"),
    ("Panned up", "U"),
    ("Panned clockwise", "U"),
    ("Tilted forward", "U"),
    ("Rolled back", "U"),
    ("It twisted to the left", "U"),
    # a sign with no stated convention
    ("Positive yaw", "U"),
    ("Rotated by -30 degrees", "U"),
    # a negated direction says what did not happen, not what did
    ("Did not turn left", "U"),
    ("Did not move left", "U"),
    ("Did not tilt up", "U"),
    ("Not to the left", "U"),
    ("It went left instead of right", "U"),
    # two alternatives, or opposite directions at once
    ("Left or right", "U2"),
    ("Either up or down", "U2"),
    ("Turned left or right", "U2"),
    ("Up and down", "U2"),
    ("Back and forth", "U2"),
]

TABLE = TRANSLATIONS + ROTATIONS + STILL + POSITIONS + COMPOUNDS + NEAR_MISSES


def test_the_table_is_large_and_covers_every_kind() -> None:
    assert len(TABLE) >= 120
    kinds = {expected.split()[0] for _, expected in TABLE}
    assert kinds >= {"T", "P", "R", "S", "B", "C", "U", "U2"}
    senses = {" ".join(expected.split()[:3]) for _, expected in ROTATIONS}
    for axis, sense in (("yaw", "left"), ("yaw", "right"), ("pitch", "up"), ("pitch", "down")):
        assert f"R {axis} {sense}" in senses
    assert {"R roll clockwise", "R roll counterclockwise"} <= senses


@pytest.mark.parametrize(("wording", "expected"), TABLE)
def test_each_option_wording_reads_as_its_claim(wording: str, expected: str) -> None:
    claim = read_phrase(wording)
    assert short(claim) == expected, (wording, claim)


@pytest.mark.parametrize(("wording", "expected"), NEAR_MISSES)
def test_near_misses_say_why_they_stay_unread(wording: str, expected: str) -> None:
    claim = read_phrase(wording)
    assert isinstance(claim, Unread) and claim.why, claim


def test_the_content_inversion_is_named_as_the_reason() -> None:
    claim = read_phrase("The scene shifted to the left")
    assert isinstance(claim, Unread) and "scene" in claim.why


@pytest.mark.parametrize(
    ("stem", "expected"),
    [
        ("From image 1 to image 2, which way did the camera move sideways?", "T left"),
        ("Between photo 1 and photo 2, where was the second camera relative to the first?", "P left"),
        ("From image 1 to image 2, which way did the camera pan?", "R yaw left"),
        ("From image 1 to image 2, which way did the camera tilt?", "R pitch up"),
    ],
)
def test_a_bare_direction_takes_the_kind_the_stem_asks(stem: str, expected: str) -> None:
    """'Leftward' / 'Upward' carry no kind: the stem's quantity gives it, when the stem is certain."""
    way = expected.split()[-1]
    options = {"left": "Leftward", "right": "Rightward", "up": "Upward", "down": "Downward"}
    others = [word for key, word in options.items() if key != way][:1]
    text = f"{stem} Options: A: {options[way]}, B: {others[0]}"
    reading = read_question(text, 2)
    assert short(reading.options["A"]) == expected, reading


# ---- whole questions: the corpus's tuning stems and pairs with this file's own option wordings ----


def _own_option_corpus(count: int, seed: int) -> list:
    """Questions built by the paraphrase corpus from its tuning stems, pairs and layouts, with the
    option lists replaced by tests/support/option_wordings.py (written for the lexicon, never
    drawn from the held-out lists)."""
    wordings = load_wordings("tuning")
    for name, entries in OPTION_WORDINGS.items():
        wordings[name] = [{"id": f"{name}.own{i:02d}", "text": text} for i, text in enumerate(entries)]
    rng = random.Random(f"own-options:{seed}")
    return [phrase(random_spec(rng, None), wordings, "tuning", f"own-{i:04d}", rng) for i in range(count)]


def test_own_option_wordings_cover_every_list_and_claim() -> None:
    corpus_lists = {name for name in load_wordings("tuning") if name.startswith("option.")}
    assert set(OPTION_WORDINGS) == corpus_lists
    for name, entries in OPTION_WORDINGS.items():
        keys = set(load_wordings("tuning")[name][0]["text"])
        assert all(set(entry) == keys for entry in entries), name


@pytest.mark.parametrize("seed", [0, 1])
def test_whole_questions_with_own_option_wordings_read_every_option_right(seed: int) -> None:
    outcomes: Counter = Counter()
    wrong = []
    for item in _own_option_corpus(300, seed):
        reading = read_question(item.text, item.image_count)
        found = option_outcomes(item, reading)
        outcomes.update(found)
        wrong += [(item.text, reading.options) for outcome in found if outcome == "option misread"]
    assert outcomes["option misread"] == 0, wrong[:3]
    assert outcomes["option unread"] == 0
    assert outcomes["option right"] == 4 * 300


@pytest.mark.parametrize(
    ("option", "expected"),
    [
        ("Image 2 was taken to the left of image 1", "P left"),
        ("Photo 2 is above photo 1", "P up"),
        ("Moved left relative to image 1", "T left"),
        # the pair reversed: its claim is the pair's claim reversed, so it is not read
        ("Image 1 was taken to the left of image 2", "U"),
        ("Photo 1 is above photo 2", "U"),
        # photos outside the pair
        ("Image 3 was taken to the left of image 1", "U"),
        # photos named by number words are checked against the pair like digits
        ("Image two is to the left of image one", "P left"),
        ("Image one is to the left of image two", "U"),
        ("Photo three was taken to the left of photo one", "U"),
    ],
)
def test_options_that_name_photos_must_name_the_pair_in_its_order(option: str, expected: str) -> None:
    other = "Image 2 was taken below image 1"
    text = f"Where was image 2 taken relative to image 1? Options: A: {option}, B: {other}"
    reading = read_question(text, 3)
    assert reading.views == (1, 2)
    assert short(reading.options["A"]) == expected, reading.options["A"]


def test_any_mix_of_the_table_s_words_reads_without_error_and_never_as_an_empty_claim() -> None:
    """Words of the table shuffled into 2-6 word phrases: every phrase gets a claim (never an
    exception, never a compound with no parts)."""
    vocabulary = sorted({word for wording, _ in TABLE for word in wording.replace(",", "").split()})
    rng = random.Random(34)
    for _ in range(3000):
        phrase_ = " ".join(rng.choice(vocabulary) for _ in range(rng.randint(2, 6)))
        claim = read_phrase(phrase_)
        assert not (isinstance(claim, Compound) and not claim.parts), phrase_
        assert isinstance(claim, Unread) or short(claim) != "U", phrase_


def test_a_bare_forward_is_a_step_except_in_a_question_about_turning() -> None:
    step = read_question(
        "From image 1 to image 2, how did the camera move? Options: A: Ahead, B: Turned left", 2
    )
    assert short(step.options["A"]) == "T forward"
    turn = read_question(
        "From image 1 to image 2, which way did the camera turn? Options: A: Forward, B: Left", 2
    )
    assert short(turn.options["A"]) == "B forward" and turn.abstain_reason
