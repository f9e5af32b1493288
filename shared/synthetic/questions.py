"""Multiple-choice spatial questions whose answers follow from a rig's exact geometry.

Four families, each asked only when the geometry leaves a clear margin:

- ``motion``: direction of the walk from one view to another (8 directions, 45-degree sectors),
  for the ``around`` and ``among`` settings where the viewer changes place.
- ``turn``: which way and how far the viewer turned, for the ``rotation`` setting.
- ``relative_position``: which object is behind / to the left / to the right of the viewer
  standing at view k.
- ``approach``: after turning 90 degrees left or right at view k and walking forward, is the
  viewer closer to or farther from an object?

Angles and distances are measured on the floor plane (see geometry.py). Questions are worded as
MindCube words them: an opening that names every image ("Based on these four images (image 1, 2,
3, and 4) showing the same room from different viewpoints:"), a setup sentence in the rotation
setting ("The image 2 was taken after turning the camera 90 degrees to the right (clockwise) from
where image 1 was taken."), then the ask ("From the viewpoint presented in image 3, what is behind
you?"). Every question shows all of the rig's views, so the view it asks about must be read from
the ask, never from the first view mentioned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.synthetic.cameras import CameraRig
from shared.synthetic.geometry import (
    MOTION_DIRECTIONS,
    angle_difference_deg,
    bearing_deg,
    camera_centre,
    heading_frame,
    horizontal_distance,
    sector_of,
    turn_deg,
)
from shared.synthetic.scene import SyntheticScene

LETTERS = "ABCDEFGH"
MIN_SECTOR_MARGIN_DEG = 7.0  # motion direction at least this far from a sector boundary
MIN_MOTION_M = 0.5
RELATION_BEARINGS = {"behind": 180.0, "to the left of": -90.0, "to the right of": 90.0}
CLEARLY_IN_DEG = 30.0  # answer object within this of the asked direction
CLEARLY_OUT_DEG = 60.0  # distractor objects at least this far from it
MIN_OBJECT_DISTANCE_M = 0.8
APPROACH_STEP_M = 1.0
MIN_APPROACH_CHANGE_M = 0.3
TURN_TOLERANCE_DEG = 5.0


@dataclass
class Question:
    family: str
    stem: str
    options: list[str]
    answer_index: int
    views: list[int]  # indices into the rig's views, in the order the images are shown
    facts: dict

    @property
    def text(self) -> str:
        """The stem with its options inline, as MindCube writes them: "... A. x B. y"."""
        return self.stem + " " + " ".join(f"{LETTERS[i]}. {o}" for i, o in enumerate(self.options))

    @property
    def answer_letter(self) -> str:
        return LETTERS[self.answer_index]


_NUMBER_WORDS = {2: "two", 3: "three", 4: "four", 5: "five", 6: "six", 7: "seven", 8: "eight"}


def opening(count: int, setting: str) -> str:
    """MindCube's opening sentence, naming every image: "(image 1, 2, 3, and 4)"."""
    numbers = [str(k) for k in range(1, count + 1)]
    if count == 2:
        listed = "image 1 and 2"
    else:
        listed = "image " + ", ".join(numbers[:-1]) + ", and " + numbers[-1]
    where = "from the same position" if setting == "rotation" else "from different viewpoints"
    number = _NUMBER_WORDS.get(count, str(count))
    return f"Based on these {number} images ({listed}) showing the same room {where}:"


def rotation_setup(rig: CameraRig, up: np.ndarray) -> str:
    """The rotation setting's setup sentence for images 1 and 2, or "" when the turn is not clean."""
    if rig.setting != "rotation" or len(rig.extrinsics) < 2:
        return ""
    angle = turn_deg(rig.extrinsics[0], rig.extrinsics[1], up)
    nearest = 45.0 * round(angle / 45.0)
    if abs(angle - nearest) > TURN_TOLERANCE_DEG or nearest == 0 or abs(nearest) >= 180:
        return ""
    side, clock = ("right", "clockwise") if nearest > 0 else ("left", "counterclockwise")
    return (
        f" The image 2 was taken after turning the camera {abs(nearest):g} degrees to the {side} ({clock}) "
        "from where image 1 was taken."
    )


def _shuffled_options(rng: np.random.Generator, answer: str, distractors: list[str]) -> tuple[list[str], int]:
    options = [answer, *distractors]
    order = rng.permutation(len(options))
    shuffled = [options[i] for i in order]
    return shuffled, shuffled.index(answer)


def _pick(rng: np.random.Generator, pool: list[str], count: int) -> list[str]:
    chosen = rng.choice(len(pool), size=min(count, len(pool)), replace=False)
    return [pool[i] for i in sorted(chosen)]


def motion_direction(first: np.ndarray, second: np.ndarray, up: np.ndarray) -> tuple[str, float, float]:
    """Phrase, bearing (deg) and sector margin (deg) of the second camera seen from the first."""
    angle = bearing_deg(first, camera_centre(second), up)
    index, margin = sector_of(angle)
    return MOTION_DIRECTIONS[index], angle, margin


def motion_questions(scene: SyntheticScene, rig: CameraRig, rng: np.random.Generator) -> list[Question]:
    questions = []
    count = len(rig.extrinsics)
    all_views = list(range(count))
    for i in range(count):
        for j in range(count):
            if i == j:
                continue
            first, second = rig.extrinsics[i], rig.extrinsics[j]
            distance = horizontal_distance(camera_centre(first), camera_centre(second), scene.up)
            phrase, angle, margin = motion_direction(first, second, scene.up)
            if distance < MIN_MOTION_M or margin < MIN_SECTOR_MARGIN_DEG:
                continue
            others = [d for d in MOTION_DIRECTIONS if d != phrase]
            options, answer = _shuffled_options(rng, phrase, _pick(rng, others, 3))
            asks = (
                f"How did I move from image {i + 1} to image {j + 1}?",
                f"In which direction did I move from the viewpoint presented in image {i + 1} to the "
                f"viewpoint presented in image {j + 1}?",
                f"From image {i + 1} to image {j + 1}, which way did the camera move?",
            )
            stem = f"{opening(count, rig.setting)} {asks[(i + j) % len(asks)]}"
            facts = {
                "pair": [i, j],
                "bearing_deg": angle,
                "sector_margin_deg": margin,
                "distance_m": distance,
            }
            questions.append(Question("motion", stem, options, answer, all_views, facts))
    return questions


def turn_phrase(angle_deg: float) -> str | None:
    """Words for a heading change that is close to a multiple of 45 degrees, else None."""
    nearest = 45.0 * round(angle_deg / 45.0)
    if abs(angle_deg - nearest) > TURN_TOLERANCE_DEG:
        return None
    magnitude = int(abs(nearest)) % 360
    if magnitude == 0:
        return "did not turn"
    if magnitude == 180:
        return "turned around by about 180 degrees"
    return f"turned {'right' if nearest > 0 else 'left'} by about {magnitude} degrees"


TURN_PHRASES = tuple(
    dict.fromkeys(turn_phrase(a) for a in (0.0, 45.0, -45.0, 90.0, -90.0, 135.0, -135.0, 180.0))
)


def turn_questions(scene: SyntheticScene, rig: CameraRig, rng: np.random.Generator) -> list[Question]:
    questions = []
    for j in range(1, len(rig.extrinsics)):
        angle = turn_deg(rig.extrinsics[0], rig.extrinsics[j], scene.up)
        phrase = turn_phrase(angle)
        if phrase is None:
            continue
        # The opposite turn is the most tempting wrong answer, so it is always offered.
        opposite = turn_phrase(-angle)
        others = [p for p in TURN_PHRASES if p not in (phrase, opposite)]
        distractors = ([opposite] if opposite != phrase else []) + _pick(rng, others, 3)
        options, answer = _shuffled_options(rng, phrase, distractors[:3])
        stem = f"{opening(len(rig.extrinsics), rig.setting)} How did I turn from image 1 to image {j + 1}?"
        all_views = list(range(len(rig.extrinsics)))
        facts = {"pair": [0, j], "turn_deg": angle}
        questions.append(Question("turn", stem, options, answer, all_views, facts))
    return questions


def relative_position_questions(
    scene: SyntheticScene, rig: CameraRig, rng: np.random.Generator
) -> list[Question]:
    questions = []
    names = scene.object_names
    all_views = list(range(len(rig.extrinsics)))
    for k, extrinsic in enumerate(rig.extrinsics):
        centre = camera_centre(extrinsic)
        objects = range(len(names))
        bearings = {o: bearing_deg(extrinsic, scene.object_centres[o], scene.up) for o in objects}
        # The answer object must not be right next to the viewer, where "behind" is ill-defined.
        far_enough = [
            o
            for o in objects
            if horizontal_distance(centre, scene.object_centres[o], scene.up) >= MIN_OBJECT_DISTANCE_M
        ]
        for relation, direction in RELATION_BEARINGS.items():
            inside = [o for o in far_enough if angle_difference_deg(bearings[o], direction) <= CLEARLY_IN_DEG]
            outside = [o for o in objects if angle_difference_deg(bearings[o], direction) >= CLEARLY_OUT_DEG]
            if len(inside) != 1 or len(outside) < 2:
                continue
            answer_object = inside[0]
            distractors = _pick(rng, [names[o] for o in outside], 3)
            options, answer = _shuffled_options(rng, names[answer_object], distractors)
            ask = {"behind": "what is behind you?", "to the left of": "what is to your left?"}.get(
                relation, "what is to your right?"
            )
            lead = ("From the viewpoint presented in", "If you are standing at the viewpoint presented in")
            stem = (
                f"{opening(len(all_views), rig.setting)}{rotation_setup(rig, scene.up)} "
                f"{lead[k % 2]} image {k + 1}, {ask}"
            )
            facts = {
                "view": k,
                "relation": relation,
                "bearings_deg": {names[o]: bearings[o] for o in objects},
            }
            questions.append(Question("relative_position", stem, options, answer, all_views, facts))
    return questions


def approach_questions(scene: SyntheticScene, rig: CameraRig, rng: np.random.Generator) -> list[Question]:
    questions = []
    all_views = list(range(len(rig.extrinsics)))
    for k, extrinsic in enumerate(rig.extrinsics):
        centre = camera_centre(extrinsic)
        _, right = heading_frame(extrinsic, scene.up)
        for turn, walk in (("left", -right), ("right", right)):
            destination = centre + APPROACH_STEP_M * walk
            if np.any(destination[:2] < scene.room_min[:2]) or np.any(destination[:2] > scene.room_max[:2]):
                continue
            for o, name in enumerate(scene.object_names):
                before = horizontal_distance(centre, scene.object_centres[o], scene.up)
                after = horizontal_distance(destination, scene.object_centres[o], scene.up)
                if abs(after - before) < MIN_APPROACH_CHANGE_M:
                    continue
                truth = f"closer to the {name}" if after < before else f"farther from the {name}"
                other = f"farther from the {name}" if after < before else f"closer to the {name}"
                options, answer = _shuffled_options(rng, truth, [other])
                stem = (
                    f"{opening(len(all_views), rig.setting)} If you are standing at the viewpoint presented "
                    f"in image {k + 1}, turn {turn} 90 degrees and walk forward {APPROACH_STEP_M:g} meter, "
                    f"will you be closer to or farther from the {name}?"
                )
                facts = {"view": k, "turn": turn, "distance_before_m": before, "distance_after_m": after}
                questions.append(Question("approach", stem, options, answer, all_views, facts))
    return questions


def questions_for_rig(
    scene: SyntheticScene, rig: CameraRig, rng: np.random.Generator, per_family: int = 2
) -> list[Question]:
    """Up to ``per_family`` questions of each family that the rig supports, chosen with rng."""
    families = [relative_position_questions, approach_questions]
    families.insert(0, turn_questions if rig.setting == "rotation" else motion_questions)
    chosen: list[Question] = []
    for family in families:
        candidates = family(scene, rig, rng)
        picks = rng.choice(len(candidates), size=min(per_family, len(candidates)), replace=False)
        chosen.extend(candidates[i] for i in sorted(picks))
    return chosen
