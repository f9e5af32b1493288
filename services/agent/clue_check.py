"""Does a program's clue cover what the question asks? Checked after every successful run.

A clue is refused (and the program sent back for repair, with a hint that names the fix) when:

- it is empty;
- it is an answer letter or an option's text rather than tool output (a one-line clue that names an
  option, or any clue that states a letter; a value among several lines is no answer);
- its camera-motion sentences are about other view pairs than the question's ("From view 1 to view
  2" for "how did I move from image 1 to image 3");
- it states no camera motion at all (the program's own arithmetic on poses) while the options read
  as camera claims between a pair the reading is sure of, and the offline answerer (which reads
  motion sentences only) is to choose;
- its rendered views were rendered from another view than the question asks from (a camera turned
  in place at view 1 for "from image 3, what is to your left?");
- it is images only while nothing here reads images (no vision answer model is configured: the
  offline answerer reads text), so the answer would be null however right the program is.

Each problem is a `ClueProblem`: its kind becomes the execution's error_kind and its message the
repair request's error; `fix` is the one-line advice (services/agent/repair_hints.py uses it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.agent.motion_clue import motion_statements
from shared.questions.choices import read_choice
from shared.questions.claims import is_read
from shared.questions.intent import QuestionIntent

# A rendered pose whose centre is this close to a view's (relative to the cameras' spread) stands there.
_SAME_PLACE = 0.05


@dataclass(frozen=True)
class ClueProblem:
    kind: str  # empty_clue | answer_letter | wrong_view | no_motion | unread_images
    message: str
    fix: str


def motion_call(intent: QuestionIntent) -> str:
    """The tool call that gives exactly the clue a self-movement question needs."""
    first, second = intent.motion_pair or (1, 2)
    return f"pySpatial.describe_camera_motion(recon, {first}, {second})"


def _pairs(pairs: list[tuple[int, int]]) -> str:
    return ", ".join(f"view {a} to view {b}" for a, b in pairs)


def _options_ask_camera_motion(intent: QuestionIntent) -> bool:
    """Options that all read as camera claims, between a pair the reading is sure of.

    Which motion (a step or a turn) need not be certain: the sentence states both. A question with
    no options (a route, a free-form question) is not checked so: its clue may be anything."""
    reading = intent.reading
    return (
        reading is not None
        and reading.views_certain
        and reading.quantity in ("translation", "rotation", "position", "motion", "still")
        and bool(reading.options)
        and all(is_read(claim) for claim in reading.options.values())
    )


def _motion_problem(intent: QuestionIntent, clue_text: str, answer_model: bool) -> ClueProblem | None:
    if intent.family != "self_movement" or intent.motion_pair is None or not clue_text:
        return None  # an image-only clue (the photos, for a vision answerer) names no pair to check
    if intent.reading is not None and not intent.reading.views_certain:
        return None  # an uncertain reading of the pair never blocks a program: it only stops the answer
    first, second = intent.motion_pair
    statements = motion_statements(clue_text)
    pairs = list(dict.fromkeys(s.pair for s in statements if s.pair is not None))
    if not pairs and not answer_model and _options_ask_camera_motion(intent):
        # Its own arithmetic on poses ("stepped unknown by 0.14 metres") says neither the pair nor the
        # determinacy; the tool's sentence says both, and it is what every answerer reads.
        return ClueProblem(
            "no_motion",
            f"the clue states no camera motion of any view pair, but the question asks how the camera "
            f"moved from image {first} to image {second}",
            f"return {motion_call(intent)}: its sentence is the measured motion, with what the photos "
            "leave undetermined",
        )
    if not pairs or intent.motion_pair in pairs:
        return None  # no sentence about any pair: not a wrong pair (the answerer says it cannot tell)
    said = f"describes {_pairs(pairs)}"
    return ClueProblem(
        "wrong_view",
        f"the clue {said}, but the question asks how the camera moved from image {first} to image {second}",
        f"return {motion_call(intent)}: it describes any pair directly (do not chain sentences)",
    )


def _nearest_view(center: np.ndarray, centers: np.ndarray) -> tuple[int, float]:
    distances = np.linalg.norm(centers - center, axis=1)
    distances = np.where(np.isfinite(distances), distances, np.inf)
    index = int(np.argmin(distances))
    return index + 1, float(distances[index])


def _render_problem(
    intent: QuestionIntent, rendered: list[np.ndarray], view_extrinsics: list[np.ndarray]
) -> ClueProblem | None:
    """Relative-direction questions turn the asked view's camera in place: every render stands there."""
    asked = intent.asked_view
    if intent.family != "relative_direction" or asked is None or not rendered or len(view_extrinsics) < 2:
        return None
    centers = np.array([-e[:3, :3].T @ e[:3, 3] for e in view_extrinsics])
    finite = centers[np.all(np.isfinite(centers), axis=1)]
    spread = float(np.max(np.linalg.norm(finite - finite.mean(axis=0), axis=1))) if len(finite) else 0.0
    tolerance = max(_SAME_PLACE * spread, 1e-6)
    if not 1 <= asked <= len(centers) or not np.all(np.isfinite(centers[asked - 1])):
        return None
    for pose in rendered:
        center = -pose[:3, :3].T @ pose[:3, 3]
        if np.linalg.norm(center - centers[asked - 1]) <= tolerance:
            continue
        used, distance = _nearest_view(center, centers)
        where = f"view {used}" if distance <= tolerance else "a place that is not image " + str(asked)
        return ClueProblem(
            "wrong_view",
            f"the program rendered from {where}; the question asks from image {asked}",
            f"start from pose = recon.extrinsics[{asked - 1}] (image {asked}) and turn it in place",
        )
    return None


def _letter_problem(intent: QuestionIntent, clue_text: str, has_images: bool) -> ClueProblem | None:
    text = clue_text.strip()
    if has_images or not text or not intent.options or len(text) > 80:
        return None
    if any(statement.pair for statement in motion_statements(text)):
        return None  # a tool's motion sentence (it names its views) may contain an option's words
    # One line is read as an answer reply is: a letter, "Answer: B", or an option's text ("Right").
    # Several lines are a listing of values, where a line that equals an option's text ("left" among
    # "3", "True", ...) is one value, not a choice: there only a stated letter is an answer.
    options = intent.options if "\n" not in text else set(intent.options)
    if read_choice(text, options) is None:
        return None
    fix = (
        f"return {motion_call(intent)}"
        if intent.family == "self_movement"
        else "return the rendered views (pySpatial.synthesize_novel_view)"
    )
    return ClueProblem(
        "answer_letter",
        f"the program returned an answer ({text!r}) instead of a clue; another model chooses the answer",
        fix + ", not an answer",
    )


def _unread_images_problem(intent: QuestionIntent, num_images: int) -> ClueProblem:
    fix = (
        f"return {motion_call(intent)}: its sentence is text"
        if intent.family == "self_movement"
        else "return the tools' text output (for example describe_camera_motion's sentence)"
    )
    views = f"{num_images} image{'s' if num_images != 1 else ''}"
    return ClueProblem(
        "unread_images",
        f"the program returned only {views}, but no vision model answers here: the answerer reads text",
        fix,
    )


def clue_problem(
    intent: QuestionIntent,
    clue_text: str | None,
    rendered: list[np.ndarray],
    num_images: int,
    view_extrinsics: list[np.ndarray] | None = None,
    answerer_reads_images: bool = True,
    answer_model: bool = True,
) -> ClueProblem | None:
    """What is wrong with the clue of a successful run (None: it covers what the question asks).

    `rendered`: the camera-from-world poses of the clue's rendered images; `num_images` counts all
    clue images (photos included); `view_extrinsics`: the input views' poses, when known;
    `answerer_reads_images`: whether a vision answer model will see the clue's images;
    `answer_model`: whether an answer model reads the clue (else the offline answerer, which reads
    motion sentences only).
    """
    text = (clue_text or "").strip()
    if text == "None" and num_images == 0:  # what a program without a `return` gives
        text = ""
    if not text and num_images == 0:
        fix = f"return {motion_call(intent)}" if intent.family == "self_movement" else "return rendered views"
        return ClueProblem("empty_clue", "the program returned an empty clue (no text, no image)", fix)
    if not text and not answerer_reads_images:
        return _unread_images_problem(intent, num_images)
    return (
        _letter_problem(intent, text, num_images > 0)
        or _motion_problem(intent, text, answer_model)
        or _render_problem(intent, rendered, view_extrinsics or [])
    )


__all__ = ["ClueProblem", "clue_problem", "motion_call"]
