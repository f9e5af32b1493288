"""The offline planner: writes a real pySpatial program for a question without any language model.

It takes the question's intent (shared.questions.intent: parsed once) and writes the program a careful
person would write; the program then runs under the same sandbox as model-written ones. Kinds:

- "motion" (self-movement): how the camera moved from view i to view j: describe_camera_motion of
  exactly that pair (the recon service describes any pair, consecutive or not).
- "behind", "left", "right", "front" and the diagonals (relative direction, rotation setting
  included): what lies in that direction from view k: turn that camera in place and render. Of a
  named object seen from view k ("what is behind the sofa"): render view k, which looks at it, and
  for a side also that view turned 90 degrees toward the side.
- "turn_and_move" (what-if): compose the turns and moves in the order asked; closer/farther questions
  get a render before the first move and one after the last; "then what is to your left?" turns once
  more for the final look.
- "around": anything else plannable: render left, right and behind of the asked view (view 1 by default).

Occlusion and object-perspective questions cannot be planned offline (see QuestionIntent.offline_reason):
`UnplannableQuestion` says why. Views are 1-based in questions and tools; `recon.extrinsics[0]` is view 1.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel

from shared.questions.intent import PoseStep, QuestionIntent, UnknownScale, view_references

ProgramKind = Literal[
    "motion",
    "behind",
    "left",
    "right",
    "front",
    "front-left",
    "front-right",
    "back-left",
    "back-right",
    "turn_and_move",
    "around",
]
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


_MOTION = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    # The sentence of exactly the asked pair, view {first} -> view {second} (any pair, consecutive or not).
    return pySpatial.describe_camera_motion(recon, {first}, {second})
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
    "front-left": "pySpatial.rotate_left(pose, angle=45)",
    "front-right": "pySpatial.rotate_right(pose, angle=45)",
    "back-left": "pySpatial.rotate_left(pose, angle=135)",
    "back-right": "pySpatial.rotate_right(pose, angle=135)",
}


def _step_line(step: PoseStep) -> str:
    if step.kind == "turn":
        if step.side == "around":
            return "pose = pySpatial.turn_around(pose)"
        return f"pose = pySpatial.rotate_{step.side}(pose, angle={step.degrees:g})"
    # Metres are scene units only in a metric reconstruction: `_metric_check` makes the program
    # say so and stop on any other, so the distance here is the metric one.
    distance = step.scene_units(METRIC)
    argument = f", distance={distance:g}" if distance is not None else ""
    return f"pose = pySpatial.move_{step.side}(pose{argument})"


METRIC = 1.0  # metres per scene unit of a metric reconstruction (recon.units == "metres")


def _metric_check(steps: list[PoseStep]) -> list[str]:
    """Program lines that stop with the reason when a step's metres cannot be placed: the
    reconstruction the program gets has no metric scale (recon.units is not "metres")."""
    for step in steps:
        try:
            step.scene_units(None)
        except UnknownScale as error:
            return ['if recon.units != "metres":', f"    return {str(error)!r}"]
    return []


def _turn_and_move_source(intent: QuestionIntent) -> str:
    """Closer/farther: render just before the first move and at the end, the pair shows what walking
    changes (with turns only, "before" is the view itself). A direction asked after the steps ("turn
    around: what is to your left?") is one more turn for the final look, rendered alone."""
    view = intent.view
    lines: list[str] = _metric_check(intent.steps)
    if intent.direction is not None and intent.comparison is None:
        lines += [_step_line(step) for step in intent.steps]
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
    return PlannedProgram(
        source=_MOTION.format(first=first, second=second),
        family="motion",
        explanation=f"camera motion from view {first} to view {second}: describe_camera_motion of that pair",
        views=[first, second],
        intent=intent,
    )


# "behind / left of <object>" seen from a view is about that object, not about the camera: the view
# already looks at it. What is behind (or in front of) it lies along that line of sight, so the view
# itself is the clue, never the camera turned around. For a side, the view (the object in sight) and
# that view turned 90 degrees toward the side: what lies beside the object, as MindCube's answers read
# it (the wall to the right of the ball seen from image 2 is the one to that camera's right).
_OBJECT_SIDE_DEGREES = 90
_OF_OBJECT = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    pose = recon.extrinsics[{index}]  # view {view}: it looks at {target}
    views = [pySpatial.synthesize_novel_view(recon, pose)]
{turn}    return views
"""
_OBJECT_TURN = {
    "left": "rotate_left", "right": "rotate_right", "front-left": "rotate_left",
    "front-right": "rotate_right", "back-left": "rotate_left", "back-right": "rotate_right",
}  # fmt: skip


def _of_object_plan(side: str, view: int, intent: QuestionIntent) -> PlannedProgram:
    target = intent.target_object or "the object"
    turn = ""
    if side in _OBJECT_TURN:
        call = f"pySpatial.{_OBJECT_TURN[side]}(pose, angle={_OBJECT_SIDE_DEGREES})"
        turn = f"    views.append(pySpatial.synthesize_novel_view(recon, {call}))  # beside {target}\n"
    source = _OF_OBJECT.format(index=view - 1, view=view, target=target, turn=turn)
    return PlannedProgram(
        source=source,
        family=side,  # type: ignore[arg-type]
        explanation=f"what is {_direction_words(side)} of {target} seen from view {view}: that view looks "
        f"at {target}; render it" + (", and turned toward that side" if turn else ""),
        views=[view],
        intent=intent,
    )


def _surrounding_plan(side: str, view: int, intent: QuestionIntent) -> PlannedProgram:
    if intent.target_object is not None:
        return _of_object_plan(side, view, intent)
    name = "ahead" if side == "front" else side.replace("-", "_")
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
