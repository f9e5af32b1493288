"""The quantity a camera question's stem asks, when no option says it (shared/questions/reading.py).

Written here from the ways people ask about a camera's motion (not from the paraphrase corpus):
the place it went to (a step), the way it looks (a turn), where one camera stands seen from the
other (a position), or any change (motion); a quantity set aside ("rotation aside") is not asked.
"""

from __future__ import annotations

import pytest

from shared.questions.reading import read_question

STEMS: list[tuple[str, str]] = [
    # a step: where the camera went
    ("Where did the camera end up going from image 1 to image 2?", "translation"),
    ("How was the camera displaced from image 1 to image 2?", "translation"),
    ("In which direction did the camera's position change from image 1 to image 2?", "translation"),
    ("Which way did the shooter step between image 1 and image 2?", "translation"),
    ("How did the camera's location differ between image 1 and image 2?", "translation"),
    ("Which way was the camera slid from image 1 to image 2?", "translation"),
    ("Without considering rotation, how did the camera move from image 1 to image 2?", "translation"),
    ("Rotation aside, where did the camera go from image 1 to image 2?", "translation"),
    ("Irrespective of any turning, which way did the camera move from image 1 to image 2?", "translation"),
    (
        "Leaving aside the change in viewing direction, how did the camera move from image 1 to image 2?",
        "translation",
    ),
    # a turn: the way it looks
    ("What change of viewing direction happened from image 1 to image 2?", "rotation"),
    ("How did the orientation change from image 1 to image 2?", "rotation"),
    ("How was the camera reoriented from image 1 to image 2?", "rotation"),
    ("How did the camera's aim shift from image 1 to image 2?", "rotation"),
    ("How did the line of sight change from image 1 to image 2?", "rotation"),
    ("Which way did the camera swivel from image 1 to image 2?", "rotation"),
    ("Position aside, how did the camera turn from image 1 to image 2?", "rotation"),
    ("Not considering any displacement, how did the camera turn from image 1 to image 2?", "rotation"),
    ("Without regard to translation, how did the camera's aim change from image 1 to image 2?", "rotation"),
    # a position: one camera seen from the other
    ("In which direction does image 2's camera lie from image 1's?", "position"),
    ("How is image 2's camera placed relative to image 1's?", "position"),
    ("Where does image 2's viewpoint lie relative to image 1's?", "position"),
    ("Which direction is image 2's camera from image 1's camera?", "position"),
    ("Where is image 2's shooting spot relative to image 1's?", "position"),
    ("Where was the photographer standing for image 2 compared with image 1?", "position"),
    # any change
    ("How did the camera's viewing direction and position change from image 1 to image 2?", "motion"),
    ("How did the camera's pose change from image 1 to image 2?", "motion"),
    ("How did the point of view change from image 1 to image 2?", "motion"),
]


@pytest.mark.parametrize(("stem", "quantity"), STEMS, ids=[s[:60] for s, _ in STEMS])
def test_the_stem_says_the_quantity(stem: str, quantity: str) -> None:
    reading = read_question(stem, 2)
    assert reading.quantity == quantity, (reading.quantity, reading.quantity_source)
    assert reading.views is not None


def test_a_stem_that_says_a_step_and_options_that_state_turns_abstain() -> None:
    reading = read_question(
        "Where did the camera end up from image 1 to image 2?\nA. It turned left B. It turned right", 2
    )
    assert reading.abstain_reason is not None and "stem" in reading.abstain_reason
    plain = read_question(
        "How did the camera move from image 1 to image 2?\nA. It turned left B. It turned right", 2
    )
    assert plain.quantity == "rotation" and plain.abstain_reason is None  # a weak verb: the options lead


@pytest.mark.parametrize(
    ("stem", "camera"),
    [
        ("What was the camera's motion from image 1 to image 2?", True),
        ("What is the camera's displacement from image 1 to image 2?", True),
        ("What was the direction of the camera's displacement from image 1 to image 2?", True),
        ("What is true of the camera's movement from image 1 to image 2?", True),
        ("What was different about the camera between image 1 and image 2?", True),
        ("What did the photographer do between image 1 and image 2?", True),
        ("From image 1 to image 2, the camera did what?", True),
        ("What is to the left of the sofa in image 2?", False),
        ("What is behind the camera in image 2?", False),
        ("What is the direction of the chair relative to the camera in image 1?", False),
    ],
)
def test_a_what_is_about_the_camera_is_a_camera_question(stem: str, camera: bool) -> None:
    # options outside the lexicon: the stem alone says whether the camera is asked about
    reading = read_question(stem + "\nA. It scooted sideways B. It bobbed", 2)
    assert reading.is_camera is camera, reading.quantity
