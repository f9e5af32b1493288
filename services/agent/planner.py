"""The offline planner: writes a real pySpatial program for a question without any language model.

It takes the question's intent (shared.questions.intent: parsed once) and writes the program a careful
person would write; the program then runs under the same sandbox as model-written ones. Kinds:

- "motion" (self-movement): how the camera moved from view i to view j. Consecutive pairs come from
  describe_camera_motion; any other pair is computed in the program from the two extrinsics, with the
  conventions of shared/geometry/camera_motion.py (scene up = mean of the cameras' -y axes, turn positive =
  left), and printed as the same kind of sentence.
- "behind", "left", "right", "front" (relative direction, rotation setting included): what lies in
  that direction from view k, or of the object seen from view k: turn that camera in place and render.
- "turn_and_move" (what-if): compose the turns and moves in the order asked; closer/farther questions
  get a render before the first move and one after the last; "then what is to your left?" turns once
  more for the final look.
- "around": anything else plannable: render left, right and behind of the asked view (view 1 by default).

Occlusion and object-perspective questions cannot be planned offline (see QuestionIntent.offline_reason):
`UnplannableQuestion` says why. Views are 1-based in questions and 0-based in code.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel

from shared.questions.intent import PoseStep, QuestionIntent, view_references

ProgramKind = Literal["motion", "behind", "left", "right", "front", "turn_and_move", "around"]
# Kept under its old name: the kind of program the planner wrote.
Family = ProgramKind


class PlanningError(ValueError):
    """The question cannot be planned for these images (e.g. it names a view that does not exist)."""


class UnplannableQuestion(Exception):
    """A well-formed question of a family the offline planner has no program for; says which and why."""

    def __init__(self, intent: QuestionIntent) -> None:
        super().__init__(intent.offline_reason or f"no offline program for {intent.family} questions")
        self.intent = intent
        self.reason = str(self)


class PlannedProgram(BaseModel):
    source: str
    family: ProgramKind
    explanation: str
    views: list[int]  # the views the program looks from, 1-based as in the question
    intent: QuestionIntent | None = None


def _check_views(views: list[int], num_images: int) -> None:
    for view in views:
        if not 1 <= view <= num_images:
            raise PlanningError(f"the question names view {view}, but there are {num_images} image(s)")


_MOTION_CONSECUTIVE = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    # View {first} -> view {second} is a consecutive pair: describe_camera_motion has a sentence for it.
    return pySpatial.describe_camera_motion(recon)
"""

# For other pairs the program works out the motion itself, with shared/geometry/camera_motion.py's rules.
_MOTION_PAIR = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    if any("central hypothesis" in warning for warning in recon.warnings):
        # The focal is unknown: the poses are one hypothesis of many, and only the service's
        # sentences say which words hold at every hypothesis (it gives one for every such pair).
        return pySpatial.describe_camera_motion(recon)
    first = np.array(recon.extrinsics[{first_index}], dtype=float)
    second = np.array(recon.extrinsics[{second_index}], dtype=float)
    up = recon.up
    if up is None:
        # Scene up as the recon service estimates it: the mean of the cameras' -y axes (y points down).
        ups = [-pose[1, :3] for pose in recon.extrinsics if all(np.isfinite(pose[1, :3]))]
        up = np.sum(np.array(ups), axis=0)
    up = np.array(up, dtype=float) / np.linalg.norm(up)
    forward_first = first[2, :3] - np.dot(first[2, :3], up) * up
    forward_first = forward_first / np.linalg.norm(forward_first)
    forward_second = second[2, :3] - np.dot(second[2, :3], up) * up
    forward_second = forward_second / np.linalg.norm(forward_second)
    right = np.cross(forward_first, up)
    center_first = -first[:, :3].T @ first[:, 3]
    center_second = -second[:, :3].T @ second[:, 3]
    step = center_second - center_first
    flat = step - np.dot(step, up) * up
    angle = float(np.degrees(np.arctan2(np.dot(flat, right), np.dot(flat, forward_first))))
    names = [
        "forward", "diagonally forward and right", "right", "diagonally back and right",
        "backward", "diagonally back and left", "left", "diagonally forward and left",
    ]
    direction = names[int(np.floor((angle + 22.5) / 45.0)) % 8]
    cross = np.dot(np.cross(forward_first, forward_second), up)
    yaw = float(np.degrees(np.arctan2(cross, np.dot(forward_first, forward_second))))
    degrees = int(5 * round(abs(yaw) / 5))
    if abs(yaw) < 10:
        turn = "without turning significantly"
    elif degrees >= 180:
        turn = "and turned around by about 180 degrees"
    elif yaw > 0:
        turn = "and turned left by about " + str(degrees) + " degrees"
    else:
        turn = "and turned right by about " + str(degrees) + " degrees"
    return "From view {first} to view {second} the camera moved " + direction + " " + turn + "."
"""

_SURROUNDING = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    pose = recon.extrinsics[{index}]  # view {view}
    {name} = {turn}
    return pySpatial.synthesize_novel_view(recon, {name})
"""

_AROUND = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    pose = recon.extrinsics[{index}]  # view {view}
    left = pySpatial.synthesize_novel_view(recon, pySpatial.rotate_left(pose, angle=90))
    right = pySpatial.synthesize_novel_view(recon, pySpatial.rotate_right(pose, angle=90))
    behind = pySpatial.synthesize_novel_view(recon, pySpatial.turn_around(pose))
    return [left, right, behind]
"""

_LOOK_AFTER_STEPS = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    pose = recon.extrinsics[{index}]  # view {view}
{steps}
"""

_TURN_AND_MOVE = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    pose = recon.extrinsics[{index}]  # view {view}
{steps}
    return [before, after]
"""


_LOOK = {
    "behind": "pySpatial.turn_around(pose)",
    "left": "pySpatial.rotate_left(pose, angle=90)",
    "right": "pySpatial.rotate_right(pose, angle=90)",
    "front": "pose",
}


def _step_line(step: PoseStep) -> str:
    if step.kind == "turn":
        if step.side == "around":
            return "pose = pySpatial.turn_around(pose)"
        return f"pose = pySpatial.rotate_{step.side}(pose, angle={step.degrees:g})"
    argument = f", distance={step.meters:g}" if step.meters is not None else ""
    return f"pose = pySpatial.move_{step.side}(pose{argument})"


def _turn_and_move_source(intent: QuestionIntent) -> str:
    """Closer/farther: render just before the first move and at the end, the pair shows what walking
    changes (with turns only, "before" is the view itself). A direction asked after the steps ("turn
    around: what is to your left?") is one more turn for the final look, rendered alone."""
    view = intent.view
    lines: list[str] = []
    if intent.direction is not None and intent.comparison is None:
        lines = [_step_line(step) for step in intent.steps]
        lines.append(f"look = {_LOOK[intent.direction]}  # what is {_direction_words(intent.direction)}")
        lines.append("return pySpatial.synthesize_novel_view(recon, look)")
        body = "\n".join("    " + line for line in lines)
        return _LOOK_AFTER_STEPS.format(index=view - 1, view=view, steps=body)
    rendered_before = False
    for step in intent.steps:
        if step.kind == "move" and not rendered_before:
            lines.append("before = pySpatial.synthesize_novel_view(recon, pose)")
            rendered_before = True
        lines.append(_step_line(step))
    if not rendered_before:
        lines.insert(0, "before = pySpatial.synthesize_novel_view(recon, pose)")
    lines.append("after = pySpatial.synthesize_novel_view(recon, pose)")
    body = "\n".join("    " + line for line in lines)
    return _TURN_AND_MOVE.format(index=view - 1, view=view, steps=body)


def _direction_words(direction: str) -> str:
    return {"behind": "behind", "front": "in front"}.get(direction, f"to the {direction}")


def _motion_plan(first: int, second: int, intent: QuestionIntent) -> PlannedProgram:
    if second == first + 1:
        source = _MOTION_CONSECUTIVE.format(first=first, second=second)
        how = "describe_camera_motion covers this consecutive pair"
    else:
        source = _MOTION_PAIR.format(
            first=first, second=second, first_index=first - 1, second_index=second - 1
        )
        how = "the program computes this non-consecutive pair from the two extrinsics"
    return PlannedProgram(
        source=source,
        family="motion",
        explanation=f"camera motion from view {first} to view {second}: {how}",
        views=[first, second],
        intent=intent,
    )


def _surrounding_plan(side: str, view: int, intent: QuestionIntent) -> PlannedProgram:
    name = "ahead" if side == "front" else side
    source = _SURROUNDING.format(index=view - 1, view=view, name=name, turn=_LOOK[side])
    of = f" {intent.target_object}" if intent.target_object else ""
    return PlannedProgram(
        source=source,
        family=side,  # type: ignore[arg-type]
        explanation=f"what is {_direction_words(side)}{' of' + of if of else ''} seen from view {view}: "
        "turn that camera in place and render",
        views=[view],
        intent=intent,
    )


def plan_intent(intent: QuestionIntent, num_images: int) -> PlannedProgram:
    """A program for a parsed question. Raises PlanningError for a view that does not exist and
    UnplannableQuestion for the families no offline program can serve."""
    if num_images < 1:
        raise PlanningError("a question needs at least one image")
    # Views the question names (an implied pair, "how did I move?" = 1 -> 2, is not checked here).
    named = [*intent.mentioned_views, *([intent.asked_view] if intent.asked_view else [])]
    _check_views(named, num_images)
    if intent.offline_reason:
        raise UnplannableQuestion(intent)
    view = intent.view
    if intent.family == "self_movement" and intent.motion_pair and num_images >= 2:
        return _motion_plan(*intent.motion_pair, intent)
    if intent.family == "what_if" and intent.steps:
        actions = ", then ".join(step.words for step in intent.steps)
        looks = (
            f"; then look {_direction_words(intent.direction)}"
            if intent.direction and not intent.comparison
            else ""
        )
        return PlannedProgram(
            source=_turn_and_move_source(intent),
            family="turn_and_move",
            explanation=f"from view {view}: {actions}{looks}; render "
            + ("the final look" if looks else "before and after the move to compare"),
            views=[view],
            intent=intent,
        )
    if intent.family == "relative_direction" and intent.direction is not None:
        return _surrounding_plan(intent.direction, view, intent)
    return PlannedProgram(
        source=_AROUND.format(index=view - 1, view=view),
        family="around",
        explanation=f"no specific family recognized: render left, right and behind of view {view}",
        views=[view],
        intent=intent,
    )


__all__ = [
    "Family",
    "PlannedProgram",
    "PlanningError",
    "ProgramKind",
    "UnplannableQuestion",
    "plan_intent",
    "view_references",
]
