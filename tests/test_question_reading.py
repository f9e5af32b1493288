"""The one reading of a camera question: the lexicon, the pair grammar, abstention, claim matching.

Tables of wordings (each row says what it must read as), then the matcher on sentences the
geometry writes for cameras built to move one way, exactly and over focal hypotheses.
"""

from __future__ import annotations

import pytest

from services.agent.answering import answer_offline
from services.agent.claim_matching import match_sentence
from services.agent.clue_check import clue_problem
from shared.geometry.motion_determinacy import motion_over_focal
from shared.questions.claims import Compound, Position, Rotation, Still, Target, Translation, Unread
from shared.questions.intent import parse_question
from shared.questions.lexicon import read_phrase
from shared.questions.reading import read_question
from shared.questions.view_pair import read_pair
from tests.test_motion_answers import clue
from tests.test_motion_determinacy import _hypotheses
from tests.test_motion_vocabulary import _axis_rotation, pair

# ---- the lexicon: every way of saying each meaning ----------------------------------------------

TRANSLATIONS = [
    ("Moved left", ("left",)),
    ("sidestepped to the left", ("left",)),
    ("strafed right", ("right",)),
    ("shifted rightward", ("right",)),
    ("It climbed", ("up",)),
    ("ascended", ("up",)),
    ("rose", ("up",)),
    ("At a greater height", ("up",)),
    ("descended", ("down",)),
    ("sank", ("down",)),
    ("dropped lower", ("down",)),
    ("At a lower height", ("down",)),
    ("proceeded", ("forward",)),
    ("approached", ("forward",)),
    ("advanced", ("forward",)),
    ("Nearer to the scene", ("forward",)),
    ("withdrew", ("backward",)),
    ("stepped back", ("backward",)),
    ("retreated", ("backward",)),
    ("moved diagonally forward and left", ("forward", "left")),
    ("slid toward the frame's upper edge", ("up",)),
]


@pytest.mark.parametrize(("phrase", "ways"), TRANSLATIONS)
def test_translations_in_every_wording(phrase: str, ways: tuple[str, ...]) -> None:
    claim = read_phrase(phrase)
    assert isinstance(claim, Translation), (phrase, claim)
    assert set(claim.ways) == set(ways)


ROTATIONS = [
    ("Turned left", "yaw", "left"),
    ("panned right", "yaw", "right"),
    ("veered left", "yaw", "left"),
    ("pivoted to the right", "yaw", "right"),
    ("looked aside to the left", "yaw", "left"),
    ("did a U-turn", "yaw", "around"),
    ("tilted up", "pitch", "up"),
    ("nodded downward", "pitch", "down"),
    ("craned upward", "pitch", "up"),
    ("angled the view down", "pitch", "down"),
    ("looked up", "pitch", "up"),
    ("rolled clockwise", "roll", "clockwise"),
    ("spun counter-clockwise", "roll", "counterclockwise"),
    ("canted clockwise", "roll", "clockwise"),
    ("banked anticlockwise", "roll", "counterclockwise"),
    ("rotated about the lens axis clockwise", "roll", "clockwise"),
    ("Counterclockwise", "roll", "counterclockwise"),
    ("did not turn", "yaw", "none"),
    ("without tilting", "pitch", "none"),
]


@pytest.mark.parametrize(("phrase", "axis", "sense"), ROTATIONS)
def test_rotations_with_their_axis_and_sense(phrase: str, axis: str, sense: str) -> None:
    claim = read_phrase(phrase)
    assert isinstance(claim, Rotation), (phrase, claim)
    assert (claim.axis, claim.sense) == (axis, sense)


@pytest.mark.parametrize(
    "phrase",
    ["Stayed still", "did not move", "It remained in place", "No motion", "stationary", "motionless"],
)
def test_still_in_every_wording(phrase: str) -> None:
    assert isinstance(read_phrase(phrase), Still)


def test_compounds_are_read_part_by_part() -> None:
    claim = read_phrase("moved left and turned right")
    assert isinstance(claim, Compound)
    assert {type(p) for p in claim.parts} == {Translation, Rotation}
    step = next(p for p in claim.parts if isinstance(p, Translation))
    turn = next(p for p in claim.parts if isinstance(p, Rotation))
    assert step.ways == ("left",) and (turn.axis, turn.sense) == ("yaw", "right")
    assert isinstance(read_phrase("stayed in place and turned left"), Rotation)


@pytest.mark.parametrize(
    ("phrase", "why"),
    [
        ("glimmered sideways", "not in the motion lexicon"),
        ("back and forth", "both forward and backward"),
        ("moved left or right", "joined by 'or'"),
        ("moved left then right", "both left and right"),
        ("turned", "no side"),
        ("not left", "negated"),
    ],
)
def test_words_outside_the_lexicon_or_saying_two_things_stay_unread(phrase: str, why: str) -> None:
    claim = read_phrase(phrase)
    assert isinstance(claim, Unread) and why in claim.why, claim


def test_closer_to_a_named_object_is_a_target_claim() -> None:
    claim = read_phrase("Closer to the red sofa")
    assert isinstance(claim, Target) and claim.change == "closer"


# ---- the pair, from grammar ---------------------------------------------------------------------

PAIRS = [
    ("How did the camera move from image 1 to image 3?", 3, (1, 3)),
    ("Between the first and the third image, which way did it turn?", 3, (1, 3)),
    ("Between the first and the last photo, how did the camera move?", 4, (1, 4)),
    ("Image 1, then image 3: how did the camera move?", 3, (1, 3)),
    ("When image 3 was taken, compared with image 1, where was the camera?", 3, (1, 3)),
    ("Relative to picture 2, where was picture 1 taken?", 2, (2, 1)),
    ("Shot 4 was shot after shot 2. Which way did the camera go?", 4, (2, 4)),
    ("Going from frame 3 back to frame 1, how did the camera move?", 3, (3, 1)),
    ("Photo two was taken before photo three. How did it move?", 3, (2, 3)),
    ("Snapshot 3 was taken earlier than snapshot 1. How did the camera move?", 3, (3, 1)),
    ("Where was the second photo taken, relative to the first camera?", 2, (1, 2)),
    ("How did the camera move?", 2, (1, 2)),
    ("Compared with the first view, how was the camera moved in the second view?", 2, (1, 2)),
    ("In which direction did the camera move from view #2 to view #1?", 2, (2, 1)),
    ("Taking shot 2 as the reference, where is the camera of shot 1?", 2, (2, 1)),
    (
        "Apart from moving, which way did it end up pointing when image 2 was taken, compared with image 1?",
        2,
        (1, 2),
    ),
    ("How did the camera move between the two photos?", 2, (1, 2)),
]


@pytest.mark.parametrize(("text", "count", "views"), PAIRS)
def test_the_pair_is_read_from_the_grammar(text: str, count: int, views: tuple[int, int]) -> None:
    reading = read_pair(text, count, default_two=True)
    assert reading.views == views and reading.certain, reading


@pytest.mark.parametrize(
    ("text", "count", "doubt"),
    [
        ("From image 1 to image 2 and from image 2 to image 3?", 3, "two readings"),
        ("From image 1 and from image 3, which way?", 3, "two readings"),
        ("How did the camera move among images 1, 2 and 3?", 3, "without saying which two"),
        ("How did the camera move to the last photo?", None, "number of photos is not known"),
        ("How did the camera move from image 1 to image 5?", 3, "beyond the 3 given"),
        ("How did the camera move?", 3, "names no photos"),
        # An order word that no construction read: the order it gives is not guessed.
        ("Photos 1 and 3 were taken in reverse order. How did the camera move?", 3, "'reverse'"),
        ("How did the camera move from the former photo to the latter one?", 2, "'former'"),
        # Two photos, one named in a way not read: not "1 to 2 by default".
        ("How did the camera move going back to the earlier shot?", 2, "in a way not read"),
        ("Relative to the other picture, where was this one taken?", 2, "in a way not read"),
    ],
)
def test_a_pair_that_reads_two_ways_is_not_guessed(text: str, count: int | None, doubt: str) -> None:
    reading = read_pair(text, count, default_two=True)
    assert reading.views is None and doubt in (reading.doubt or ""), reading


# ---- the whole reading: options lead, quantity, frame, abstention --------------------------------


def test_options_lead_whatever_the_stem_says() -> None:
    reading = read_question(
        "Looking at photo 1 and photo 2, what about the camera? "
        "A. Rolled clockwise B. Rolled counterclockwise",
        2,
    )
    assert reading.quantity == "rotation" and reading.views == (1, 2) and reading.options_lead
    assert reading.abstain_reason is None and reading.certain
    intent = parse_question(reading.text, 2)
    assert intent.family == "self_movement" and intent.motion_pair == (1, 2)


def test_the_stem_gives_bare_options_their_kind() -> None:
    tilt = read_question("Which way did the camera tilt from image 1 to image 2? A. Up B. Down", 2)
    assert all(isinstance(c, Rotation) and c.axis == "pitch" for c in tilt.options.values())
    place = read_question(
        "Where was the second photo taken, relative to the first camera? A. Above B. Below", 2
    )
    assert place.quantity == "position" and all(isinstance(c, Position) for c in place.options.values())
    assert "position of the second camera" in place.summary


def test_the_frame_and_the_summary() -> None:
    reading = read_question(
        "Apart from moving, which way did the camera end up pointing in image 3 compared with image 1, "
        "in the first image's directions? A. Turned left B. Turned right",
        3,
    )
    assert reading.views == (1, 3) and reading.quantity == "rotation"
    assert reading.frame is not None and reading.frame.kind == "view_axes" and reading.frame.view == 1
    assert reading.summary == "read as: camera rotation from image 1 to image 3, in image 1's axes"
    room = read_question("How did the camera move in the room from image 1 to image 2? A. Up B. Down", 2)
    assert room.frame is not None and room.frame.kind == "room"


@pytest.mark.parametrize(
    ("text", "count", "reason"),
    [
        (
            "From image 1 to image 2 and from image 2 to image 3? A. Moved left B. Moved right",
            3,
            "two readings",
        ),
        ("How did the camera change from image 1 to image 2? A. Left B. Right", 2, "reads two ways"),
        (
            "Which way did the camera turn from image 1 to image 2? A. Moved left B. Moved right",
            2,
            "the stem asks about rotation",
        ),
    ],
)
def test_readings_that_must_abstain_say_why(text: str, count: int, reason: str) -> None:
    reading = read_question(text, count)
    assert reading.abstain_reason is not None and reason in reading.abstain_reason, reading


def test_object_questions_and_what_ifs_are_not_camera_questions() -> None:
    objects = read_question(
        "From the viewpoint of image 2, what is to the right of the ball? A. the chair B. a lamp", 2
    )
    assert objects.quantity == "object_relation" and not objects.is_camera
    what_if = read_question(
        "If you turn left 90 degrees from image 1, will you be closer to the sofa? A. Closer to the sofa "
        "B. Farther from the sofa",
        2,
    )
    assert not what_if.is_camera


# ---- matching claims to the measured motion ------------------------------------------------------


def test_a_translation_question_is_not_blocked_by_a_turn_in_the_clue() -> None:
    text = clue(pair(step_in_camera=(-0.3, 0.0, 0.0), rotation_in_camera=_axis_rotation("y", -30.0)))
    assert "turned" in text and "left" in text
    reading = read_question(
        "Which way did the camera shift from image 1 to image 2? A. Sidestepped left "
        "B. Sidestepped right C. Climbed D. Descended",
        2,
    )
    assert match_sentence(reading, text).letter == "A"


def test_an_undetermined_quantity_abstains_with_its_range_and_a_determined_one_answers() -> None:
    # Left by 12-42 degrees at every field of view; the step swings from forward to forward-left.
    motion = motion_over_focal(
        _hypotheses([12, 25, 42], [[0.0, 0.0, 1.0], [-0.3, 0.0, 1.0], [-1.0, 0.0, 1.0]])
    )
    turn = read_question("How did the camera pan from image 1 to image 2? A. Panned left B. Panned right", 2)
    assert match_sentence(turn, motion.sentence).letter == "A"
    step = read_question(
        "Which way did the camera travel from image 1 to image 2? A. Forward B. Left C. Backward", 2
    )
    undetermined = match_sentence(step, motion.sentence)
    assert undetermined.letter is None and not undetermined.determined
    assert "cannot be determined" in (undetermined.reason or "") and undetermined.range == motion.sentence


def test_a_position_question_is_answered_from_the_step_in_its_own_words() -> None:
    text = clue(pair(step_in_camera=(0.0, -0.25, 0.0)))  # camera y points down: -y is up
    question = (
        "Where was the second photo taken, relative to the first camera? "
        + "A. Below it B. Above it C. To its left"
    )
    result = answer_offline(parse_question(question, 2), text, [])
    assert result.answer == "B", result.reason
    assert "position of the second camera" in result.reasoning


def test_an_unread_option_stops_an_answer_the_others_do_not_decide() -> None:
    text = clue(pair(step_in_camera=(-0.2, 0.0, 0.2)))
    reading = read_question(
        "Which way did the camera move from image 1 to image 2? A. Moved left B. Moved right C. glimmered", 2
    )
    result = match_sentence(reading, text)
    assert result.letter is None and "option C could not be read" in (result.reason or "")


def test_an_uncertain_pair_never_blocks_a_program_it_only_stops_the_answer() -> None:
    other_pair = "From view 2 to view 3 the camera moved right without turning significantly."
    doubtful = parse_question(
        "From image 1 to image 2 and from image 2 to image 3, how did I move? A. Left B. Right", 3
    )
    assert doubtful.reading is not None and not doubtful.reading.views_certain
    assert clue_problem(doubtful, other_pair, [], 0) is None  # not sent back for repair
    answer = answer_offline(doubtful, other_pair, [])
    assert answer.answer is None and "two readings" in (answer.reason or "")
    certain = parse_question("How did I move from image 1 to image 3? A. Left B. Right", 3)
    problem = clue_problem(certain, other_pair, [], 0)
    assert problem is not None and problem.kind == "wrong_view"  # a certain pair: the pointed hint


def test_no_rotation_at_all_is_no_turn_no_tilt_and_no_roll() -> None:
    claim = read_phrase("did not rotate")
    assert isinstance(claim, Compound)
    assert {(p.axis, p.sense) for p in claim.parts} == {("yaw", "none"), ("pitch", "none"), ("roll", "none")}
    rolled = clue(pair(rotation_in_camera=_axis_rotation("z", 20.0)))
    reading = read_question(
        "How did the camera rotate from image 1 to image 2? A. rolled clockwise B. rolled counterclockwise "
        "C. did not rotate",
        2,
    )
    assert match_sentence(reading, rolled).letter == "A"
