"""Evidence, not assertions: output a program typed in itself is not a clue."""

from __future__ import annotations

from services.agent.evidence import typed_in_lines
from shared.questions.intent import parse_question
from tests.support.model_replies import recorded_replies
from tests.test_model_replies import cleaned

TURN_QUESTION = (
    "How did I turn from view 1 to view 2? A. did not turn B. turned left by about 90 degrees "
    "C. turned right by about 90 degrees D. turned right by about 45 degrees"
)
TOOL_PROGRAM = (
    "def program(input_scene):\n"
    "    return pySpatial.describe_camera_motion(pySpatial.reconstruct(input_scene))\n"
)


def test_tool_output_is_evidence_even_when_it_states_an_option() -> None:
    sentence = "From view 1 to view 2 the camera stayed in place and turned left by about 90 degrees."
    assert typed_in_lines(sentence, TOOL_PROGRAM, parse_question(TURN_QUESTION)) == (sentence, [])


def test_an_option_typed_into_the_program_is_not_evidence() -> None:
    program = cleaned(recorded_replies()[0].reply)[0]  # returns "turned left by about 90 degrees"
    text, notes = typed_in_lines("turned left by about 90 degrees", program, parse_question(TURN_QUESTION))
    assert text is None and "option B's text" in notes[0]


def test_a_template_filled_with_its_own_words_is_not_evidence() -> None:
    program = cleaned(recorded_replies()[21].reply)[0]  # f"Turned {turn_direction} by about {d:.2f} units."
    question = "Where did I go? A. toward the door B. toward the window"
    text, notes = typed_in_lines("Turned right by about 0.41 units.", program, parse_question(question))
    assert text is None and "its own words" in notes[0]


def test_numbers_in_the_programs_words_pass_unless_they_claim_a_motion() -> None:
    program = "def program(s):\n    a = 3\n    return f'heading change: {a} degrees'\n"
    assert (
        typed_in_lines("heading change: 35 degrees", program, parse_question("Which way? A. x B. y"))[0]
        is not None
    )


def test_only_typed_lines_are_left_out() -> None:
    program = (
        "def program(s):\n    r = pySpatial.reconstruct(s)\n"
        "    return 'B. turned left by about 90 degrees\\n' + pySpatial.describe_camera_motion(r)\n"
    )
    clue = (
        "B. turned left by about 90 degrees\n"
        "From view 1 to view 2 the camera moved forward without turning significantly."
    )
    text, notes = typed_in_lines(clue, program, parse_question(TURN_QUESTION))
    assert text.startswith("From view 1 to view 2") and len(notes) == 1
