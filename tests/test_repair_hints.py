"""The asked-view check and the pointed repair hints, on clues and errors from real sandbox runs."""

from __future__ import annotations

import numpy as np
import pytest

from services.agent.clue_check import clue_problem
from services.agent.codegen import repair_hints
from services.agent.repair_hints import pointed_hints
from shared.questions.intent import parse_question
from tests.test_sandbox import FALSE_POSITIVES_CLUE, PointSceneTools, run

OPENING = "Based on these three images (image 1, 2, and 3) showing the same room from different viewpoints:"
ONE_TO_THREE = parse_question(
    f"{OPENING} How did I move from image 1 to image 3? A. Left B. Right C. Forward", 3
)
TWO_TO_THREE = parse_question(f"{OPENING} How did I move from image 2 to image 3? A. Left B. Right", 3)
FROM_THREE = parse_question(f"{OPENING} From image 3, what is to your left? A. a lamp B. a sofa", 3)
CONSECUTIVE = (
    "From view 1 to view 2 the camera moved right without turning significantly.\n"
    "From view 2 to view 3 the camera moved diagonally forward and right and turned left by about 30 degrees."
)


def test_consecutive_sentences_do_not_cover_a_one_to_three_question() -> None:
    problem = clue_problem(ONE_TO_THREE, CONSECUTIVE, [], 0)
    assert problem is not None and problem.kind == "wrong_view"
    assert "view 1 to view 2, view 2 to view 3" in problem.message and "image 1 to image 3" in problem.message
    assert "describe_camera_motion(recon, 1, 3)" in problem.fix


def test_the_one_to_two_sentence_does_not_answer_another_pair() -> None:
    first = CONSECUTIVE.splitlines()[0]
    assert clue_problem(TWO_TO_THREE, first, [], 0).kind == "wrong_view"
    assert clue_problem(TWO_TO_THREE, CONSECUTIVE, [], 0) is None  # the asked pair is there
    assert clue_problem(ONE_TO_THREE, "From view 1 to view 3 the camera moved right.", [], 0) is None


def test_renders_from_another_view_than_the_asked_one() -> None:
    tools = PointSceneTools()
    views = [np.asarray(e, dtype=float) for e in tools.extrinsics]
    problem = clue_problem(FROM_THREE, None, [views[0]], 1, views)
    assert problem is not None and problem.kind == "wrong_view"
    assert "rendered from view 1" in problem.message and "asks from image 3" in problem.message
    assert "recon.extrinsics[2]" in problem.fix
    assert clue_problem(FROM_THREE, None, [views[2]], 1, views) is None


def test_empty_clues_and_answers_instead_of_clues() -> None:
    assert clue_problem(ONE_TO_THREE, "", [], 0).kind == "empty_clue"
    assert clue_problem(ONE_TO_THREE, "None", [], 0).kind == "empty_clue"  # a program with no `return`
    assert clue_problem(ONE_TO_THREE, "B", [], 0).kind == "answer_letter"
    assert clue_problem(ONE_TO_THREE, "Right", [], 0).kind == "answer_letter"
    assert clue_problem(ONE_TO_THREE, "The answer is right.", [], 0).kind == "answer_letter"
    assert clue_problem(ONE_TO_THREE, "3 views\nAnswer: B", [], 0).kind == "answer_letter"


def test_an_option_word_among_listed_values_is_no_answer() -> None:
    # the sandbox's ordinary-code control prints "left" as one of thirteen values
    left_or_right = parse_question("Which way did the camera move from view 1 to view 2? A. left B. right", 2)
    assert "left" in FALSE_POSITIVES_CLUE.splitlines()
    assert clue_problem(left_or_right, FALSE_POSITIVES_CLUE, [], 0) is None
    # Not an answer; but no motion sentence either, which the offline answerer needs.
    assert clue_problem(left_or_right, FALSE_POSITIVES_CLUE, [], 0, answer_model=False).kind == "no_motion"
    assert clue_problem(left_or_right, "left", [], 0).kind == "answer_letter"


# Errors as the real sandbox reports them (each run here), and the hint each class must give.
PROGRAMS = {
    "rejected": ("def program(input_scene):\n    return open('x').read()\n", "`open` is not available"),
    "tool": (
        "def program(input_scene):\n    recon = pySpatial.reconstruct(input_scene)\n"
        "    return pySpatial.describe_camera_motion(recon, 0, 2)\n",
        "describe_camera_motion said",
    ),
    "import": ("def program(input_scene):\n    import os\n    return 'x'\n", "Delete every import line"),
}


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_hints_of_real_sandbox_errors(name: str) -> None:
    source, expected = PROGRAMS[name]
    result = run(source)
    assert not result.ok
    hints = repair_hints(result.error, result.error_kind, ONE_TO_THREE)
    assert any(expected in hint for hint in hints), (result.error, hints)
    if name == "tool":  # the tool's own message, with what it wants
        assert any("views are numbered 1..3" in hint for hint in hints)
    if name == "rejected":
        assert any("input_scene.images" in hint for hint in hints)  # the allowed alternative


def test_each_clue_class_has_its_own_hint() -> None:
    assert "describe_camera_motion(recon, 1, 3)" in pointed_hints("x", "wrong_view", ONE_TO_THREE)[0]
    assert "recon.extrinsics[2]" in pointed_hints("x", "wrong_view", FROM_THREE)[0]
    assert "returned an answer, not a clue" in pointed_hints("x", "answer_letter", ONE_TO_THREE)[0]
    assert "returned an answer, not a clue" in pointed_hints("x", "not_evidence", ONE_TO_THREE)[0]
    assert "empty clue" in pointed_hints("x", "empty_clue", ONE_TO_THREE)[0]
    assert "ran out of time" in pointed_hints("timed out after 20 s", "timeout", ONE_TO_THREE)[0]
    assert "np.linalg.solve" in pointed_hints("line 3: 'np.linalg.inv' is not available in the sandbox")[0]


def test_an_image_only_clue_nothing_reads_goes_back_with_a_text_call() -> None:
    problem = clue_problem(ONE_TO_THREE, None, [], 2, answerer_reads_images=False)
    assert problem is not None and problem.kind == "unread_images"
    assert "2 images" in problem.message and "describe_camera_motion(recon, 1, 3)" in problem.fix
    assert clue_problem(ONE_TO_THREE, None, [], 2) is None  # a vision answerer looks at them
    # text with the images is read: the check is only for clues that are images alone
    sentence = "From view 1 to view 3 the camera moved right."
    assert clue_problem(ONE_TO_THREE, sentence, [], 2, answerer_reads_images=False) is None
    hint = pointed_hints("x", "unread_images", ONE_TO_THREE)[0]
    assert "can look at images" in hint and "describe_camera_motion(recon, 1, 3)" in hint
    assert "synthesize_novel_view" not in pointed_hints("x", "unread_images", FROM_THREE)[0]


def test_a_clue_of_its_own_pose_arithmetic_is_sent_back_for_the_motion_sentence() -> None:
    # A real model's clue (Qwen2.5-Coder-1.5B, held-out live run): numbers of its own, no pair, no
    # determinacy. With a certain reading of a camera question, the tool's sentence is asked for.
    own_arithmetic = "The photographer stepped unknown by 0.14 metres."
    problem = clue_problem(TWO_TO_THREE, own_arithmetic, [], 0, answer_model=False)
    assert problem is not None and problem.kind == "no_motion"
    assert "image 2 to image 3" in problem.message and "describe_camera_motion(recon, 2, 3)" in problem.fix
    assert "describe_camera_motion(recon, 2, 3)" in pointed_hints("x", "no_motion", TWO_TO_THREE)[0]
    # An uncertain pair never blocks a program; a question not about the camera is not checked so.
    doubtful = parse_question(
        "From image 1 to image 2 and from image 2 to image 3, how did I move? A. Left B. Right", 3
    )
    assert doubtful.reading is not None and not doubtful.reading.views_certain
    assert clue_problem(doubtful, own_arithmetic, [], 0, answer_model=False) is None
    assert clue_problem(FROM_THREE, own_arithmetic, [], 0, answer_model=False) is None
    # An answer model reads any clue; a question with no options (a route) may have any clue.
    assert clue_problem(TWO_TO_THREE, own_arithmetic, [], 0) is None
    free_form = parse_question("How did I move from image 2 to image 3?", 3)
    assert clue_problem(free_form, own_arithmetic, [], 0, answer_model=False) is None
