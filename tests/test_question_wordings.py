"""The parser on the released wordings issue 22 lists, and on every question template we generate."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from shared.questions.intent import parse_question
from shared.synthetic.cameras import SETTINGS
from shared.synthetic.dataset import _scene_and_rig
from shared.synthetic.questions import (
    approach_questions,
    motion_questions,
    relative_position_questions,
    turn_questions,
)

OPENING = "Based on these three images (image 1, 2, and 3) showing the same room from different viewpoints:"
OPTIONS = " A. the sofa B. the lamp C. the table D. the door"


@pytest.mark.parametrize(
    ("ask", "family", "direction", "target", "view"),
    [
        ("From image 2, what is to my front?", "relative_direction", "front", None, 2),
        ("From the viewpoint presented in image 3, what is to your front?", "relative_direction", "front",
         None, 3),
        (
            "If you are positioned where the sofa is and facing the same direction, what would be to the "
            "left of the ball?",
            "object_perspective", "left", "the ball", None,
        ),
        ("From image 1, what is to the front-left of me?", "relative_direction", "front-left", None, 1),
        ("From image 1, what is to my front-right?", "relative_direction", "front-right", None, 1),
        ("From image 2, what is to the back-left of the ball?", "relative_direction", "back-left",
         "the ball", 2),
        ("From image 2, what is front-right of the orange ball?", "relative_direction", "front-right",
         "the orange ball", 2),
        ("From image 3, what is behind of the ball?", "relative_direction", "behind", "the ball", 3),
    ],
)  # fmt: skip
def test_released_direction_wordings(ask, family, direction, target, view) -> None:
    intent = parse_question(f"{OPENING} {ask}{OPTIONS}", 3)
    assert (intent.family, intent.direction, intent.target_object, intent.asked_view) == (
        family, direction, target, view
    )  # fmt: skip


@pytest.mark.parametrize(
    "ask",
    [
        "From image 1, if you turn left and walk forward 1 meter, will you be closer to the lamp?",
        "From image 2, if you walk forward 2 meters, do you get closer to the lamp?",
        "Standing at image 1, turn right 90 degrees and move forward: will you get closer to the lamp?",
    ],
)
def test_released_closer_wordings(ask: str) -> None:
    intent = parse_question(f"{OPENING} {ask} A. Yes B. No", 3)
    assert (intent.family, intent.comparison, intent.target_object) == ("what_if", "distance", "the lamp")
    assert intent.steps and intent.asked_view in (1, 2)


# What each synthetic generator's questions must parse as.
GENERATOR_FAMILY = {"motion": "self_movement", "turn": "self_movement", "relative": "relative_direction",
                    "approach": "what_if"}  # fmt: skip


def _every_synthetic_question():
    for setting in SETTINGS:
        for index in range(2):
            scene, rig, _ = _scene_and_rig(22, index, setting)
            rng = np.random.default_rng(index)
            generators = [relative_position_questions, approach_questions]
            generators.insert(0, turn_questions if rig.setting == "rotation" else motion_questions)
            for generator in generators:
                yield from ((question, len(rig.extrinsics)) for question in generator(scene, rig, rng))


def test_every_synthetic_template_parses_with_no_unknowns() -> None:
    seen = set()
    for question, views in _every_synthetic_question():
        intent = parse_question(question.text, views)
        kind = question.family.split("_")[0]
        seen.add(kind)
        assert intent.family == GENERATOR_FAMILY.get(kind, intent.family) != "unknown", question.text
        assert intent.options and intent.asked_view is not None, question.text
        if intent.family == "self_movement":
            assert intent.motion_pair is not None, question.text
        if intent.family == "relative_direction":
            assert intent.direction is not None, question.text
    assert seen >= {"motion", "turn", "relative", "approach"}


def test_every_mindcube_fixture_parses_with_no_unknowns() -> None:
    fixtures = Path(__file__).parent / "data" / "mindcube" / "raw" / "MindCube_fixtures.jsonl"
    records = [json.loads(line) for line in fixtures.read_text().splitlines() if line.strip()]
    assert records
    for record in records:
        intent = parse_question(record["question"], len(record["images"]), record["id"])
        assert intent.family != "unknown", record["question"]
