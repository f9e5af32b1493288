"""Camera questions asked in another view's axes: answered there, or refused naming the frame.

The motion sentences state the step in the start view's image axes. After a large turn, a step that
is "forward" in image 1's axes is "left" or "right" in image 2's, so a question asked in image 2's
axes must never get image 1's answer. Every expectation here comes from the exact cameras of the
pair: the step and the turn are read in the asked view's own axes from the poses.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from services.agent.answering import answer_offline
from services.agent.claim_matching import match_sentence
from services.agent.free_form import answer_offline as answer_in_words
from shared.geometry.camera_motion import direction_name
from shared.geometry.motion_determinacy import motion_over_focal
from shared.questions.intent import parse_question
from shared.questions.reading import read_question
from tests.test_motion_answers import clue
from tests.test_motion_determinacy import _hypotheses
from tests.test_motion_vocabulary import _axis_rotation, pair

STEPS = "A. Left B. Right C. Forward D. Backward"
LETTER_OF_STEP = {"left": "A", "right": "B", "forward": "C", "backward": "D"}
TURNS = "A. Turned left B. Turned right"
LETTER_OF_TURN = {"left": "A", "right": "B"}
FORWARD = (0.0, 0.0, 0.5)


def _centre(pose: np.ndarray) -> np.ndarray:
    return -pose[:, :3].T @ pose[:, 3]


def true_heading(cameras: np.ndarray, view: int) -> float:
    """The heading of camera 2's step in (1-based) `view`'s image axes (0 forward, + right)."""
    step = cameras[view - 1, :, :3] @ (_centre(cameras[1]) - _centre(cameras[0]))
    return float(np.degrees(np.arctan2(step[0], step[2])))


def true_step(cameras: np.ndarray, view: int) -> str:
    """The compass word of camera 2's step, in (1-based) `view`'s image axes, from the poses."""
    return direction_name(true_heading(cameras, view))


def true_turn(cameras: np.ndarray, view: int) -> str:
    """Which way the viewing direction swung about `view`'s up axis (camera -y), from the poses."""
    up = -cameras[view - 1, 1, :3]
    first, second = cameras[0, 2, :3], cameras[1, 2, :3]
    return "left" if float(up @ np.cross(first, second)) > 0 else "right"  # right-handed about up


def _ask(stem: str, options: str, text: str, count: int = 2):
    return answer_offline(parse_question(f"{stem} {options}", count), text, [])


@pytest.mark.parametrize("turn_deg", [-90.0, 90.0])
@pytest.mark.parametrize(
    "stem",
    [
        "Which way did the camera move from image 1 to image 2?",
        "Which way did the camera move from image 1 to image 2, in image 1's axes?",
        "In the directions of the first photo, where did the camera go between photo 1 and photo 2?",
    ],
)
def test_the_start_views_axes_answer_as_before(turn_deg: float, stem: str) -> None:
    cameras = pair(step_in_camera=FORWARD, rotation_in_camera=_axis_rotation("y", turn_deg))
    result = _ask(stem, STEPS, clue(cameras))
    assert result.answer == LETTER_OF_STEP[true_step(cameras, 1)], result.reason


END_STEMS = [
    "From image 1 to image 2, which way did the camera move, in the directions of image 2?",
    "Which way did the camera move from image 1 to image 2, in image 2's axes?",
    "Using the second photo's directions, which way did the camera go between photo 1 and photo 2?",
    "Which way did the camera move from image 1 to image 2, in the coordinates of the last picture?",
]


@pytest.mark.parametrize("turn_deg", [-90.0, 90.0])
@pytest.mark.parametrize("stem", END_STEMS)
def test_a_step_asked_in_the_end_views_axes_after_a_turn_is_answered_in_those_axes(
    turn_deg: float, stem: str
) -> None:
    cameras = pair(step_in_camera=FORWARD, rotation_in_camera=_axis_rotation("y", turn_deg))
    # The scene is one where the two frames disagree: image 1's answer would be wrong here.
    assert true_step(cameras, 1) == "forward" and true_step(cameras, 2) in ("left", "right")
    reading = read_question(f"{stem} {STEPS}", 2)
    assert reading.frame is not None and reading.frame.view == 2 and reading.frame_certain
    result = _ask(stem, STEPS, clue(cameras))
    assert result.answer == LETTER_OF_STEP[true_step(cameras, 2)], result.reason


@pytest.mark.parametrize("turn_deg", [-90.0, 180.0])
def test_a_sentence_without_the_end_views_step_is_refused_naming_the_frame(turn_deg: float) -> None:
    cameras = pair(step_in_camera=FORWARD, rotation_in_camera=_axis_rotation("y", turn_deg))
    text = clue(cameras)
    older = re.sub(r"; in view 2's image axes it [^;.]+", "", text)  # as sentences before the clause
    assert older != text and true_step(cameras, 1) != true_step(cameras, 2)
    result = _ask(END_STEMS[1], STEPS, older)
    assert result.answer is None and "asked in image 2's axes" in (result.reason or ""), result
    assert _ask(END_STEMS[1], STEPS, text).answer == LETTER_OF_STEP[true_step(cameras, 2)]


@pytest.mark.parametrize("step", [(-0.3, 0.0, 0.0), (0.0, 0.0, -0.4), (0.3, 0.0, 0.0)])
def test_a_step_without_rotation_is_answered_in_the_end_views_axes(step: tuple[float, float, float]) -> None:
    cameras = pair(step_in_camera=step)
    stem = "Which way did the camera move from image 1 to image 2, in image 2's axes?"
    result = _ask(stem, STEPS, clue(cameras))
    assert result.answer == LETTER_OF_STEP[true_step(cameras, 2)], result.reason


@pytest.mark.parametrize("turn_deg", [-60.0, -90.0, 45.0, 90.0])
def test_a_turn_alone_is_answered_in_the_end_views_axes(turn_deg: float) -> None:
    cameras = pair(step_in_camera=FORWARD, rotation_in_camera=_axis_rotation("y", turn_deg))
    stem = "Which way did the camera turn from image 1 to image 2, in image 2's axes?"
    result = _ask(stem, TURNS, clue(cameras))
    assert result.answer == LETTER_OF_TURN[true_turn(cameras, 2)], result.reason


def test_a_turn_with_a_tilt_asked_in_the_end_views_axes_is_refused() -> None:
    rotation = _axis_rotation("y", 60.0) @ _axis_rotation("x", 20.0)  # right 60, then up 20
    text = clue(pair(rotation_in_camera=rotation))
    assert "turned right" in text and "tilted up" in text
    stem = "Which way did the camera tilt from image 1 to image 2, in image 2's axes?"
    result = _ask(stem, "A. Tilted up B. Tilted down", text)
    assert result.answer is None and "image 2's axes" in (result.reason or ""), result
    start = _ask(stem.replace("image 2's axes", "image 1's axes"), "A. Tilted up B. Tilted down", text)
    assert start.answer == "A", start.reason


def test_a_frame_outside_the_pair_or_an_objects_point_of_view_is_refused() -> None:
    cameras = pair(step_in_camera=FORWARD, rotation_in_camera=_axis_rotation("y", 90.0))
    text = clue(cameras)
    third = _ask("Which way did the camera move from image 1 to image 2, in image 3's axes?", STEPS, text, 3)
    assert third.answer is None and "image 3's axes" in (third.reason or ""), third
    lamp = _ask(
        "Which way did the camera move from image 1 to image 2, from the lamp's perspective?", STEPS, text
    )
    assert lamp.answer is None and "the lamp's point of view" in (lamp.reason or ""), lamp


def test_claims_without_axes_are_answered_in_any_frame() -> None:
    cameras = pair(rotation_in_camera=_axis_rotation("y", 90.0))  # turned in place: not still
    stem = "Did the camera stay still from image 1 to image 2, in image 2's axes?"
    result = _ask(stem, "A. It stayed still B. Turned right", cameras_text := clue(cameras))
    assert result.answer == "B", (cameras_text, result.reason)


def test_a_free_form_answer_in_the_end_views_axes_is_refused_after_a_turn() -> None:
    cameras = pair(step_in_camera=FORWARD, rotation_in_camera=_axis_rotation("y", 90.0))
    question = parse_question("How did the camera move from image 1 to image 2, in image 2's axes?", 2)
    result = answer_in_words(question, clue(cameras), [])
    assert result.answer is None and "image 2's axes" in (result.reason or ""), result
    start = parse_question("How did the camera move from image 1 to image 2?", 2)
    assert "forward" in (answer_in_words(start, clue(cameras), []).answer or "")


def test_over_focal_hypotheses_keep_the_same_rules() -> None:
    # Left by 12-42 degrees at every field of view, the step forward to forward-left (in image 1's axes).
    motion = motion_over_focal(
        _hypotheses([12, 25, 42], [[0.0, 0.0, 1.0], [-0.3, 0.0, 1.0], [-1.0, 0.0, 1.0]])
    )
    turn = read_question(
        f"Which way did the camera pan from image 1 to image 2, in image 2's axes? {TURNS}", 2
    )
    assert match_sentence(turn, motion.sentence).letter == "A"  # a turn alone reads the same in both
    step = read_question(
        f"Which way did the camera move from image 1 to image 2, in image 2's axes? {STEPS}", 2
    )
    refused = match_sentence(step, motion.sentence)
    assert refused.letter is None and "asked in image 2's axes" in (refused.reason or "")


def test_axes_named_in_words_the_reading_does_not_read_are_refused_not_defaulted() -> None:
    cameras = pair(step_in_camera=FORWARD, rotation_in_camera=_axis_rotation("y", 90.0))
    stem = (
        "Which way did the camera move from image 1 to image 2? Answer with the axes set by the later photo."
    )
    reading = read_question(f"{stem} {STEPS}", 2)
    assert not reading.frame_certain and "axes" in reading.frame_source
    result = _ask(stem, STEPS, clue(cameras))
    assert result.answer is None and "axes" in (result.reason or ""), result
    # a note that names one photo is read: image 2's axes, where the step is stated too
    named = "Which way did the camera move from image 1 to image 2? Answer with the axes set by image 2."
    assert read_question(f"{named} {STEPS}", 2).frame.view == 2  # type: ignore[union-attr]
    assert _ask(named, STEPS, clue(cameras)).answer == LETTER_OF_STEP[true_step(cameras, 2)]
    read = "Use the directions of image 2 itself. Which way did the camera move from image 1 to image 2?"
    assert _ask(read, STEPS, clue(cameras)).answer == LETTER_OF_STEP[true_step(cameras, 2)]
