"""Camera questions on templeRing photo pairs and triples, each option's truth from the calibrated cameras.

Not a bench of its own: bench.mmsi_templering and bench.paraphrase_answers ask these. For a pair of
true cameras the words of every quantity (turn, tilt, roll; the lateral, depth and vertical step;
in view A's image axes) come from the same rules the service uses (`motion_over_focal` at the one
true hypothesis). A question asks one quantity: the option that holds is one of its stated words,
the others are claims those words contradict (the opposite sense, or any sense of an axis whose word
is "none", or "still"), so exactly one option holds.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

import numpy as np

from bench.templering_data import relative_pose
from shared.geometry.motion_determinacy import PairHypotheses, motion_over_focal
from tests.support.paraphrases import STILL, ClaimSpec

STEP_AXES = {"lateral": ("left", "right"), "depth": ("forward", "backward"), "vertical": ("up", "down")}
TURN_AXES = {
    "turn": ("yaw", ("left", "right")),
    "tilt": ("pitch", ("up", "down")),
    "roll": ("roll", ("clockwise", "counterclockwise")),
}
# Turning a photo 90 degrees clockwise: the camera turns about its optical axis.
SIDEWAYS = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def true_quantities(first: np.ndarray, second: np.ndarray) -> dict[str, str]:
    """Word per quantity of the true relative pose (unit step), from first to second."""
    rotation, translation = relative_pose(first, second)
    unit = translation / np.linalg.norm(translation)
    motion = motion_over_focal(PairHypotheses(0, 1, [0.0], [rotation.tolist()], [unit.tolist()], [0]))
    return {name: motion.quantities[name].words[0] for name in (*STEP_AXES, *TURN_AXES)}


def _step_claims(words: dict[str, str], kind: str) -> tuple[list[ClaimSpec], list[ClaimSpec]]:
    """(claims that hold, claims the words contradict) of a step (translation or position)."""
    holds, false = [], []
    for axis, ways in STEP_AXES.items():
        for way in ways:
            (holds if words[axis] == way else false).append(ClaimSpec(kind, (way,)))
    return holds, false


def _turn_claims(words: dict[str, str]) -> tuple[list[ClaimSpec], list[ClaimSpec]]:
    holds, false = [], []
    for name, (axis, senses) in TURN_AXES.items():
        for sense in senses:
            (holds if words[name] == sense else false).append(ClaimSpec("rotation", axis=axis, sense=sense))
    return holds, false


def claims_for(
    words: dict[str, str], quantity: str, rng: random.Random
) -> tuple[tuple[ClaimSpec, ...], int] | None:
    """Four options of one quantity (one holds, three are contradicted) and the index of the true
    one; None when no word of that quantity is stated."""
    if quantity == "rotation":
        holds, false = _turn_claims(words)
    else:
        holds, false = _step_claims(words, quantity)
    if not holds:
        return None
    if quantity != "position":
        false.append(STILL)
    options = [rng.choice(holds), *rng.sample(false, 3)]
    rng.shuffle(options)
    truth = next(i for i, claim in enumerate(options) if claim in holds)
    return tuple(options), truth


@dataclass(frozen=True)
class TempleSet:
    """Photos of the ring (1-based image numbers), as taken or all turned 90 degrees clockwise."""

    images: tuple[int, ...]
    sideways: bool

    def label(self) -> str:
        return "-".join(map(str, self.images)) + (" sideways" if self.sideways else "")


def true_extrinsics(cameras, photo_set: TempleSet) -> list[np.ndarray]:
    truth = [cameras[n - 1].extrinsic for n in photo_set.images]
    if photo_set.sideways:
        truth = [np.concatenate([SIDEWAYS @ t[:, :3], SIDEWAYS @ t[:, 3:]], 1) for t in truth]
    return truth


def photos(root, cameras, photo_set: TempleSet) -> list[np.ndarray]:
    from bench.templering_data import load_image

    pictures = [load_image(root, cameras[n - 1].name) for n in photo_set.images]
    if photo_set.sideways:
        pictures = [np.ascontiguousarray(np.rot90(p, -1)) for p in pictures]
    return pictures
