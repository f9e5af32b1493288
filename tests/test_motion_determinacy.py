"""Camera motion over an unknown focal: which words every field-of-view hypothesis shares.

The pure rules on hand-made hypotheses, the store/load of hypotheses (reconstruction format 5, older
files still read), and the classical backbone on real photos with the focal withheld.
"""

from __future__ import annotations

import numpy as np
import pytest

from shared.geometry.motion_determinacy import FocalHypotheses, PairHypotheses, motion_over_focal
from shared.geometry.poses import axis_angle_matrix
from shared.geometry.reconstruction import Reconstruction
from tests.test_reconstruction import sample

_DOWN = np.array([0.0, 1.0, 0.0])  # camera +y points down: a turn about it is a yaw


def _hypotheses(yaws_deg: list[float], steps: list[list[float]]) -> PairHypotheses:
    """A pair at fields of view 30, 40, ...: turned by `yaws_deg` (+ = left), stepped by `steps`."""
    rotations, translations = [], []
    for yaw, step in zip(yaws_deg, steps, strict=True):
        # Camera 2's axes in camera 1's: a left turn is a rotation about -y (up) by +yaw.
        orientation = axis_angle_matrix(-_DOWN, yaw)
        rotation = orientation.T  # x_second = R^T (x_first - centre)
        centre = np.asarray(step, float) / np.linalg.norm(step)
        rotations.append(rotation.tolist())
        translations.append((-rotation @ centre).tolist())
    fovs = [30.0 + 10 * k for k in range(len(yaws_deg))]
    return PairHypotheses(0, 1, fovs, rotations, translations, [100] * len(fovs))


def test_a_turn_that_holds_at_every_focal_is_determined_and_a_step_that_varies_is_not():
    # The hand check: left by 12-42 degrees at every FOV; the step swings forward-left.
    motion = motion_over_focal(
        _hypotheses([12, 25, 42], [[0.0, 0.0, 1.0], [-0.3, 0.0, 1.0], [-1.0, 0.0, 1.0]])
    )
    assert motion.turn_determined and motion.turns == ["left"]
    assert motion.yaw_range_deg == pytest.approx((12.0, 42.0), abs=1e-6)
    assert not motion.direction_determined
    assert motion.directions == ["forward", "diagonally forward and left"]
    assert motion.fov_range_deg == (30.0, 50.0) and motion.hypotheses == 3
    assert motion.sentence.startswith(
        "From view 1 to view 2 the camera turned left by 12 to 42 degrees (determined) and moved "
        "forward or diagonally forward and left (not determined; heading -45 to 0 degrees, 0 = forward, "
        "+ = right)"
    )
    assert motion.heading_range_deg == pytest.approx((-45.0, 0.0), abs=1e-6)
    np.testing.assert_allclose(motion.translation_directions[0], [0.0, 0.0, 1.0], atol=1e-9)


def test_a_turn_that_changes_side_over_the_focal_range_is_not_determined():
    motion = motion_over_focal(_hypotheses([-15, 3, 20], [[1.0, 0.0, 0.0]] * 3))
    assert not motion.turn_determined and motion.turns == ["right", "none", "left"]
    assert motion.direction_determined and motion.directions == ["right"]
    assert "turned between 15 degrees right and 20 degrees left (not determined)" in motion.sentence
    assert "moved right (determined; heading 90 to 90 degrees" in motion.sentence


def test_reversed_pair_turns_the_other_way():
    pair = _hypotheses([12, 42], [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    stored = FocalHypotheses([30.0, 40.0, 50.0], 40.0, [pair])
    back = motion_over_focal(stored.for_pair(1, 0))
    assert back.turns == ["right"] and back.yaw_range_deg == pytest.approx((-42.0, -12.0), abs=1e-6)
    # Seen from view 2, view 1 is behind, and behind-left once view 2 has turned 42 degrees.
    assert back.directions == ["backward", "diagonally back and left"]
    assert stored.for_pair(0, 2) is None


def test_hypotheses_are_stored_and_read_back_and_older_files_have_none():
    recon = sample(num_points=20, with_depth=False)
    recon.focal_hypotheses = FocalHypotheses(
        [10.0, 20.0, 30.0], 20.0, [_hypotheses([12, 42], [[0.0, 0.0, 1.0], [-1.0, 0.0, 1.0]])]
    )
    restored = Reconstruction.from_bytes(recon.to_bytes())
    assert restored.focal_hypotheses == recon.focal_hypotheses
    assert Reconstruction.from_bytes(sample(num_points=20).to_bytes()).focal_hypotheses is None


# ---- the agent answers only what every hypothesis agrees on ---------------------------------------

_ASKS = "Based on these two images (image 1 and 2) showing the same scene: "
_TURN_QUESTION = (
    "Based on these two images (image 1 and 2) showing the same scene: How did I turn from image 1 to "
    "image 2? A. turned left by about 45 degrees B. turned right by about 45 degrees C. did not turn"
)
_MOVE_QUESTION = (
    "Based on these two images (image 1 and 2) showing the same scene: How did I move from image 1 to "
    "image 2? A. forward B. left C. diagonally forward and left D. backward"
)


def test_the_agent_answers_a_choice_that_holds_at_every_focal_and_refuses_one_that_does_not():
    from services.agent.answering import UNDETERMINED, answer_offline
    from shared.questions.intent import parse_question

    # Left by 30 to 60 degrees at every focal: "left by about 45" is the nearest option throughout.
    left = motion_over_focal(_hypotheses([30, 45, 60], [[-0.3, 0.0, 1.0]] * 3))
    turned = answer_offline(parse_question(_TURN_QUESTION), left.sentence, [])
    assert turned.answer == "A", turned.reasoning
    # The step swings from forward to forward-left over the focal range: no answer, with the range.
    walked = answer_offline(
        parse_question(_MOVE_QUESTION),
        motion_over_focal(
            _hypotheses([12, 25, 42], [[0.0, 0.0, 1.0], [-0.3, 0.0, 1.0], [-1.0, 0.0, 1.0]])
        ).sentence,
        [],
    )
    assert walked.answer is None
    assert UNDETERMINED in walked.reason and "12 to 42 degrees" in walked.reason
    assert "options A, C each fit" in walked.reason
    # A turn from 15 right to 20 left straddles three options: refused too.
    straddle = motion_over_focal(_hypotheses([-15, 3, 20], [[1.0, 0.0, 0.0]] * 3))
    refused = answer_offline(parse_question(_TURN_QUESTION), straddle.sentence, [])
    assert refused.answer is None and UNDETERMINED in refused.reason
    # The same step, determined, answers the move question.
    right = answer_offline(
        parse_question(_MOVE_QUESTION.replace("B. left", "B. right")), straddle.sentence, []
    )
    assert right.answer == "B", right.reasoning


def test_a_question_without_options_gets_only_the_determined_words():
    from services.agent.free_form import answer_offline
    from shared.questions.intent import parse_question

    ask = _ASKS + "How did I move from image 1 to image 2?"
    swinging = motion_over_focal(
        _hypotheses([12, 25, 42], [[0.0, 0.0, 1.0], [-0.3, 0.0, 1.0], [-1.0, 0.0, 1.0]])
    )
    result = answer_offline(parse_question(ask), swinging.sentence, [])
    assert (
        result.answer == "turned left by 12 to 42 degrees (the step cannot be determined from these photos)"
    )
    straddle = motion_over_focal(_hypotheses([-15, 3, 20], [[1.0, 0.0, 0.0]] * 3))
    stepped = answer_offline(parse_question(ask), straddle.sentence, [])
    assert stepped.answer == "moved right (the turn cannot be determined from these photos)"
