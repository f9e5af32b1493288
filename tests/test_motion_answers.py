"""Options matched by meaning through one motion vocabulary, and free-form words, offline.

The clues are sentences shared/geometry/camera_motion.py writes for cameras built to move one way,
so every word is checked from the geometry to the answer.
"""

from __future__ import annotations

import numpy as np
import pytest

from services.agent.answering import answer_offline
from shared.geometry.camera_motion import describe_camera_motion
from shared.questions.intent import parse_question
from shared.questions.motion_words import asked_frame, asked_motion, read_motion
from tests.test_motion_vocabulary import WORLD_UP, _axis_rotation, level_rotation, pair


def clue(cameras: np.ndarray) -> str:
    return "\n".join(m.sentence for m in describe_camera_motion(cameras, up=WORLD_UP, scene_scale=1.0))


CASES = [
    ((0.0, 0.2, 0.0), np.eye(3), "Down", "down"),
    ((0.0, 0.2, 0.0), np.eye(3), "It moved down", "down"),
    ((0.0, 0.2, 0.0), np.eye(3), "downward", "down"),
    ((0.0, 0.2, 0.0), np.eye(3), "Below the first camera", "down"),
    ((0.0, -0.2, 0.0), np.eye(3), "Up", "up"),
    ((0.0, 0.0, 0.0), np.eye(3), "It stayed still", "stayed still"),
    ((0.0, 0.0, 0.0), _axis_rotation("y", -30.0), "panned left", "turned left by about 30 degrees"),
    ((0.0, 0.0, 0.0), _axis_rotation("x", 12.0), "tilted upward", "tilted up by about 10 degrees"),
    ((0.0, 0.0, 0.0), _axis_rotation("x", -12.0), "The camera tilted down", "tilted down"),
    ((0.0, 0.0, 0.0), _axis_rotation("z", 20.0), "rolled clockwise", "rolled clockwise by about 20 degrees"),
    ((0.0, 0.0, 0.0), _axis_rotation("z", -20.0), "Rotated counter-clockwise", "rolled counterclockwise"),
    ((0.3, 0.0, 0.0), np.eye(3), "Right", "moved right"),
    ((0.0, 0.0, -0.3), np.eye(3), "It moved backward", "moved backward"),
]
DISTRACTORS = ["It moved to the left", "Forward", "It moved up", "It stayed still", "tilted downward"]


@pytest.mark.parametrize(("step", "rotation", "option", "words"), CASES)
def test_the_option_that_means_the_motion_is_chosen(step, rotation, option, words):
    text = clue(pair(step_in_camera=step, rotation_in_camera=rotation))
    others = [d for d in DISTRACTORS if read_motion(d).stated() != read_motion(option).stated()]
    letters = "ABCD"
    options = [*others[:3], option]
    question = "How did the camera move from image 1 to image 2? " + " ".join(
        f"{letter}. {text}" for letter, text in zip(letters, options, strict=True)
    )
    result = answer_offline(parse_question(question, 2), text, [])
    assert result.answer == "D", (text, result.reason)
    free = answer_offline(parse_question("How did the camera move from image 1 to image 2?", 2), text, [])
    assert words in free.answer and free.method == "offline_text", (text, free.answer)


def test_the_question_gives_bare_words_their_sense():
    tilted = clue(pair(rotation_in_camera=_axis_rotation("x", 15.0)))
    question = "Which way did the camera tilt from image 1 to image 2? A. Up B. Down C. Left D. Right"
    assert asked_motion(parse_question(question, 2).ask) == "tilt" == parse_question(question, 2).motion_asked
    assert answer_offline(parse_question(question, 2), tilted, []).answer == "A"


def test_the_room_frame_is_read_when_the_question_names_it():
    sideways = level_rotation(roll_deg=90.0)
    center = np.array([0.0, 0.0, 1.0])
    poses = [np.hstack([sideways, (-sideways @ c)[:, None]]) for c in (center, center + 0.3 * WORLD_UP)]
    text = clue(np.stack(poses))
    options = " A. Left B. Right C. Up D. Down"
    in_photo = parse_question("Which way did the camera move from image 1 to image 2?" + options, 2)
    in_room = parse_question(
        "Which way did the camera move in the room from image 1 to image 2?" + options, 2
    )
    assert asked_frame(in_room.text) == "gravity" == in_room.motion_frame and in_photo.motion_frame == "image"
    assert answer_offline(in_photo, text, []).answer == "A"
    assert answer_offline(in_room, text, []).answer == "C"


def test_closer_to_the_target_matches_an_approach():
    cameras = pair(step_in_camera=(0.0, 0.0, 0.5))
    ahead = -cameras[0, :, :3].T @ cameras[0, :, 3] + 2.0 * cameras[0, 2, :3]
    [motion] = describe_camera_motion(
        cameras, up=WORLD_UP, scene_scale=1.0, target=ahead, target_name="the lamp"
    )
    question = (
        "From image 1 to image 2, how did the camera move relative to the lamp? "
        "A. Farther from the lamp B. Closer to the lamp"
    )
    assert answer_offline(parse_question(question, 2), motion.sentence, []).answer == "B"


def test_two_options_that_both_fit_give_no_answer():
    text = clue(pair(step_in_camera=(0.0, 0.2, 0.0)))
    question = "Which way did the camera move from image 1 to image 2? A. Down B. downward C. Up"
    result = answer_offline(parse_question(question, 2), text, [])
    assert result.answer is None and "all fit" in result.reason


def test_a_turn_in_place_is_not_still():
    assert read_motion("It stayed in the same position but turned left").stated() == {"turn": "turn left"}
    assert read_motion("The camera remained stationary").still


@pytest.mark.parametrize(
    ("rotation", "choice", "words"),
    [
        (_axis_rotation("x", 20.0), "C", "did not turn significantly"),  # templeRing's views 1 and 2
        (_axis_rotation("z", -20.0), "C", "did not turn significantly"),
        (_axis_rotation("y", -30.0) @ _axis_rotation("x", 20.0), "A", "turned left by about 30 degrees"),
    ],
)
def test_a_tilt_or_roll_without_a_turn_named_did_not_turn(rotation, choice, words):
    """The sentence names every rotation over its threshold, so one naming only a tilt did not turn."""
    text = clue(pair(step_in_camera=(0.0, 0.3, 0.0), rotation_in_camera=rotation))
    asked = "How did the camera turn from image 1 to image 2?"
    question = asked + " A. Left B. Right C. It did not turn significantly"
    result = answer_offline(parse_question(question, 2), text, [])
    assert result.answer == choice, (text, result.reason)
    free = answer_offline(parse_question(asked, 2), text, [])
    assert free.answer == words, (text, free.answer, free.reason)
