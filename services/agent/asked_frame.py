"""Whether a motion measured in the start view's axes answers a question asked in another frame.

The motion sentences (shared/geometry/camera_motion.py, motion_determinacy.py) state the step and the
rotation in the start view's image axes (and, apart, the room's gravity frame). A question may ask
in another frame: "in image 2's directions", "from the lamp's point of view". What carries over:

- still, and closer to / farther from a target: no axes at all;
- a rotation about one axis (only a turn, or only a tilt, or only a roll named): the relative
  rotation leaves its own axis fixed, so that axis has the same coordinates in the start and the end
  view's axes, and its sense and angle read the same in both. A rotation that names two axes splits
  into turn, tilt and roll differently per frame (a 90-degree turn plus a tilt is, in the end view's
  axes, a turn plus a roll), so it does not carry over;
- a step, when the views did not rotate significantly (their axes then agree within the
  thresholds the start frame is read with). After a turn, a step "forward" in image 1's axes is
  "left" or "right" in image 2's: the sentence then states the step in the end view's axes too
  ("in view 2's image axes it moved left"), and that is the step matched (`in_asked_frame`). A
  sentence over focal hypotheses states no such clause, so there the step is refused.

Anything else is refused with the frame named: a wrong frame gives a wrong answer, worse than none.
A view outside the pair, or an object's point of view, carries only what has no axes. The room's
frame is the sentence's gravity clause (claim_matching.py), and a frame the question does not state
is the start view's, the convention every sentence states.
"""

from __future__ import annotations

from collections.abc import Iterable

from services.agent.motion_clue import MotionStatement
from shared.questions.motion_words import MotionReading
from shared.questions.reading import QuestionReading

_NO_AXES = frozenset({"still", "target"})
_STEP = frozenset({"direction", "vertical"})
_ROTATION = frozenset({"turn", "tilt", "roll"})


def measured_rotations(statement: MotionStatement) -> set[str]:
    """Which of turn, tilt and roll the sentence names (over focal hypotheses: any hypothesis may;
    a quantity an older sentence leaves unstated may be anything, so it counts)."""
    over = statement.over_focal
    if over is not None:
        spans = {"turn": over.yaw_range_deg, "tilt": over.tilt_range_deg, "roll": over.roll_range_deg}
        return {name for name, span in spans.items() if span is not None or name in over.unstated}
    reading = statement.reading_for("image")
    named = {"turn": reading.turn not in (None, "no turn"), "tilt": reading.tilt not in (None, "no tilt")}
    named["roll"] = reading.roll is not None
    return {name for name, said in named.items() if said}


def _end_step(reading: QuestionReading, statement: MotionStatement) -> MotionReading | None:
    """The step the sentence states in the asked view's axes, when that view ends the pair."""
    frame, pair = reading.frame, reading.views
    if frame is None or frame.kind != "view_axes" or pair is None or frame.view != pair[1]:
        return None
    if statement.end_axes is None or statement.end_axes[0] != frame.view:
        return None
    return statement.end_axes[1]


def in_asked_frame(
    reading: QuestionReading, statement: MotionStatement, said: MotionReading
) -> MotionReading:
    """The start-frame reading `said` with its step in the asked view's axes where the sentence
    states it there (the rest is the start frame's, as `frame_refusal` allows)."""
    end = _end_step(reading, statement)
    if end is None:
        return said
    return said.model_copy(update={"direction": end.direction, "vertical": end.vertical})


def frame_refusal(
    reading: QuestionReading, statement: MotionStatement, keys: Iterable[str], *, end_step_used: bool = True
) -> str | None:
    """Why the start-frame motion cannot answer the quantities `keys` (a MotionReading's fields) in the
    frame the question asks; None when it can. `end_step_used`: the caller reads the step through
    `in_asked_frame` (the free-form words do not)."""
    frame, pair = reading.frame, reading.views
    asked = set(keys) - _NO_AXES
    if frame is None or frame.kind == "room" or pair is None or not asked:
        return None
    if not reading.frame_certain and reading.frame_source:
        return f"the question names its axes in words this reading does not read ({reading.frame_source!r})"
    if frame.kind == "object":
        return f"asked from the {frame.object}'s point of view, which this answer cannot yet express"
    start, end = pair
    if frame.view == start:
        return None
    cannot = f"asked in image {frame.view}'s axes, which this answer cannot yet express"
    if frame.view != end:
        return f"{cannot} (image {frame.view} is not one of the two compared)"
    rotated = measured_rotations(statement)
    step_known = end_step_used and _end_step(reading, statement) is not None
    if asked & _STEP and rotated and not step_known:
        return (
            f"{cannot}: the step is measured in image {start}'s axes, and the camera "
            f"{'may have ' if statement.over_focal is not None else ''}rotated between the two"
        )
    if asked & _ROTATION and len(rotated) > 1:
        combined = " and ".join(sorted(rotated))
        return f"{cannot}: the rotation combines {combined}, which split differently per frame"
    return None


__all__ = ["frame_refusal", "in_asked_frame", "measured_rotations"]
