"""Notes on whose directions a camera question means, written for this file (not taken from the
paraphrase corpus): a sentence of its own that speaks of directions or axes and names one photo
names the photo whose axes are meant (shared/questions/reading.py); one that names several photos,
or says whose axes are not meant, leaves the frame unread, so the answer is refused rather than
given in axes not asked.
"""

from __future__ import annotations

import itertools

import pytest

from shared.questions.reading import read_question

NOTES = (
    "Directions are relative to {A}'s camera.",
    "Left and right are as seen by the photographer of {A}.",
    "All directions are in {A}'s coordinate system.",
    "Use {A} as the reference frame.",
    "Take {A}'s orientation as the reference.",
    "Directions refer to {A}.",
    "Left, right, up and down are those of {A}.",
    "Give directions in the coordinates of {A}.",
    "Directions are measured in the camera frame of {A}.",
    "Answer from the point of view of the camera that took {A}.",
    "Directions are given from the viewpoint of {A}.",
    "The axes are those of {A}'s camera.",
    "Use the axes of {A}.",
    "Directions follow {A}'s image axes.",
    "Describe directions in {A}'s own frame.",
    "Directions are with respect to {A}.",
    "Interpret directions relative to {A}.",
    "Directions are expressed in {A}'s camera coordinates.",
    "Read directions in the frame of the camera of {A}.",
    "Directions are as the photographer saw them when taking {A}.",
    "Use {A}'s camera axes for directions.",
    "Assume the coordinate frame of {A}.",
    "Directions are defined by {A}.",
    "The reference frame is {A}'s.",
)
# (the photo the note names, how it is named, the pair asked)
NAMED = (
    (1, "image 1", "from image 1 to image 2"),
    (2, "the second photo", "going from the first photo to the second photo"),
    (2, "picture two", "from picture 1 to picture 2"),
)
_OPTIONS = "\nA. It moved left\nB. It moved right"


@pytest.mark.parametrize(("note", "named"), list(itertools.product(NOTES, NAMED)))
def test_a_note_on_directions_names_the_photo_whose_axes_are_meant(note: str, named: tuple) -> None:
    view, words, pair = named
    reading = read_question(f"{note.format(A=words)} How did the camera move {pair}?{_OPTIONS}", 2)
    assert reading.frame is not None and reading.frame.kind == "view_axes"
    assert (reading.frame.view, reading.frame_certain) == (view, True)
    assert reading.views == (1, 2)


@pytest.mark.parametrize(
    "note",
    [
        "Directions are those of image 1, not image 2.",
        "Directions are not those of image 2.",
        "Directions are as seen in image 1 or image 2.",
        "Left and right are judged in image 1 and image 2 alike.",
    ],
)
def test_a_note_that_names_several_photos_or_denies_one_leaves_the_frame_unread(note: str) -> None:
    reading = read_question(f"{note} How did the camera move from image 1 to image 2?{_OPTIONS}", 2)
    assert not reading.frame_certain and reading.frame_source  # the answer is refused, naming it


def test_a_note_on_the_sense_of_a_roll_names_no_frame() -> None:
    note = "Clockwise is counted as seen from behind the camera, looking along the lens."
    reading = read_question(f"{note} How did the camera roll from image 1 to image 2?{_OPTIONS}", 2)
    assert reading.frame is not None and reading.frame.view == 1 and reading.frame_source == ""
