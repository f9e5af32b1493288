"""The offline planner: writes a real pySpatial program for a question without any language model.

It recognizes a few question families and writes the program a careful person would write; the
program then runs under the same sandbox as model-written ones. Families:

- "motion": how the camera moved from view i to view j. Consecutive pairs come from
  describe_camera_motion; any other pair is computed in the program from the two extrinsics, with the
  conventions of shared/camera_motion.py (scene up = mean of the cameras' -y axes, turn positive =
  left), and printed as the same kind of sentence.
- "behind", "left", "right": what lies behind / to the left / to the right of view k: turn that camera
  in place (turn_around, rotate_left 90, rotate_right 90) and render.
- "turn_and_move": "if I turn left and walk forward ...": compose the pose tools in the order asked and
  render before and after.
- "around": anything else: render left, right and behind of the asked view (view 1 by default).

Views are 1-based in questions ("image 3", "the third view", "the last photo") and 0-based in code.
"""

from __future__ import annotations

import re
from typing import Literal

from pydantic import BaseModel

Family = Literal["motion", "behind", "left", "right", "turn_and_move", "around"]


class PlanningError(ValueError):
    """The question cannot be planned for these images (e.g. it names a view that does not exist)."""


class PlannedProgram(BaseModel):
    source: str
    family: Family
    explanation: str
    views: list[int]  # the views the program looks from, 1-based as in the question


# ---- view references --------------------------------------------------------------------------

_NOUN = r"(?:images?|views?|pictures?|photos?|photographs?|frames?|shots?|snapshots?|viewpoints?)"
_ORDINALS = {
    "first": 1, "second": 2, "third": 3, "fourth": 4, "fifth": 5,
    "sixth": 6, "seventh": 7, "eighth": 8, "ninth": 9, "tenth": 10,
}  # fmt: skip
_ORDINAL = r"(first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|last|final|\d+(?:st|nd|rd|th))"
_NUMBERED = re.compile(
    rf"\b{_NOUN}\s*(?:#|no\.?\s*|number\s+)?(\d+)((?:\s*(?:,|and|to|&|->|→|-)\s*\d+\b)*)", re.IGNORECASE
)
_ORDINAL_REF = re.compile(rf"\b{_ORDINAL}\s+(?:[a-z]+\s+)?{_NOUN}\b", re.IGNORECASE)


def _ordinal_value(word: str, num_images: int) -> int:
    word = word.lower()
    if word in ("last", "final"):
        return num_images
    if word in _ORDINALS:
        return _ORDINALS[word]
    return int(re.match(r"\d+", word).group())


def view_references(question: str, num_images: int) -> list[int]:
    """The views a question names, 1-based, in order of mention ("views 1 and 3" gives [1, 3])."""
    found: list[tuple[int, int]] = []
    for match in _NUMBERED.finditer(question):
        found.append((match.start(1), int(match.group(1))))
        for extra in re.finditer(r"\d+", match.group(2) or ""):
            found.append((match.start(2) + extra.start(), int(extra.group())))
    for match in _ORDINAL_REF.finditer(question):
        found.append((match.start(), _ordinal_value(match.group(1), num_images)))
    return [view for _, view in sorted(found)]


def _check_views(views: list[int], num_images: int) -> None:
    for view in views:
        if not 1 <= view <= num_images:
            raise PlanningError(f"the question names view {view}, but there are {num_images} image(s)")


# ---- families ------------------------------------------------------------------------------

# A move not yet made: "if I turn ...", "after turning ...", "you turn left and walk ..." (not "did I turn").
_HYPOTHETICAL = re.compile(
    r"\b(?:if|suppose|supposing|imagine|were to|after (?:i |you )?(?:turn|turning|rotat\w*|walk\w*|mov\w*))\b"
    r"|(?<!did )\b(?:you|i|we) (?:then )?(?:turn|rotate|walk|move|step|go)\b"
)
_MOTION_VERB = re.compile(
    r"\b(?:move|moved|moving|movement|walk|walked|travel(?:l?ed)?|went|step(?:ped)?|shift(?:ed)?|"
    r"turn|turned|rotate|rotated|rotation|displace(?:d|ment)?|translat(?:e|ed|ion))\b"
)
_BETWEEN_VIEWS = re.compile(rf"\b(?:from|between)\b.*\b(?:to|and)\b.*{_NOUN}|{_NOUN}.*\bto\b.*{_NOUN}")
_BEHIND = re.compile(
    r"\bbehind (?:me|you|us|the (?:camera|viewer|photographer|person))\b|\bat (?:my|your) back\b"
    r"|\bturn(?:ed)? around\b|\bopposite direction\b"
)
_LEFT = re.compile(
    r"\b(?:to|on|at) (?:my|your|the camera's|the viewer's) left\b|\bleft of (?:me|you)\b|\bmy left\b"
)
_RIGHT = re.compile(
    r"\b(?:to|on|at) (?:my|your|the camera's|the viewer's) right\b|\bright of (?:me|you)\b|\bmy right\b"
)
_ACTION = re.compile(
    r"\b(?:turn|turns|turned|turning|rotate|rotates|rotated|rotating)\s+"
    r"(?:(?:by\s+)?(\d+(?:\.\d+)?)\s*(?:°|degrees?)\s+)?(?:to\s+(?:the|my|your)\s+)?(left|right|around)"
    r"(?:\s+(?:by\s+)?(\d+(?:\.\d+)?)\s*(?:°|degrees?))?"
    r"|\b(?:walk|walks|walked|walking|move|moves|moved|moving|step|steps|go|goes|going|head|heads)\s+"
    r"(?:\w+\s+){0,2}(forward|forwards|ahead|straight|back|backward|backwards)\b"
    r"(?:\s+(?:by\s+)?(\d+(?:\.\d+)?)\s*(?:m|meters?|metres?)\b)?"
)

_MOTION_CONSECUTIVE = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    # View {first} -> view {second} is a consecutive pair: describe_camera_motion has a sentence for it.
    return pySpatial.describe_camera_motion(recon)
"""

# For other pairs the program works out the motion itself, with shared/camera_motion.py's rules.
_MOTION_PAIR = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
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

_TURN_AND_MOVE = """\
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    pose = recon.extrinsics[{index}]  # view {view}
{steps}
    return [before, after]
"""


def _pose_steps(question: str) -> list[tuple[str, str, bool]]:
    """(program line, words, is a move) for each turn or move the question asks for, in order.

    A distance stated in meters is passed on (right for metric backbones); otherwise the default.
    """
    steps = []
    for match in _ACTION.finditer(question):
        before_angle, side, after_angle, move, meters = match.groups()
        if side == "around":
            steps.append(("pose = pySpatial.turn_around(pose)", "turn around", False))
        elif side:
            angle = float(before_angle or after_angle or 90)
            line = f"pose = pySpatial.rotate_{side}(pose, angle={angle:g})"
            steps.append((line, f"turn {side} {angle:g} degrees", False))
        else:
            way = "backward" if move in ("back", "backward", "backwards") else "forward"
            argument = f", distance={float(meters):g}" if meters else ""
            words = f"move {way}" + (f" {float(meters):g} m" if meters else "")
            steps.append((f"pose = pySpatial.move_{way}(pose{argument})", words, True))
    return steps


def _turn_and_move_source(view: int, steps: list[tuple[str, str, bool]]) -> str:
    """Render just before the first move and at the end: the pair shows what walking changes.

    With turns only, "before" is the view itself and "after" the turned view.
    """
    lines = []
    rendered_before = False
    for line, _, is_move in steps:
        if is_move and not rendered_before:
            lines.append("before = pySpatial.synthesize_novel_view(recon, pose)")
            rendered_before = True
        lines.append(line)
    if not rendered_before:
        lines.insert(0, "before = pySpatial.synthesize_novel_view(recon, pose)")
    lines.append("after = pySpatial.synthesize_novel_view(recon, pose)")
    body = "\n".join("    " + line for line in lines)
    return _TURN_AND_MOVE.format(index=view - 1, view=view, steps=body)


def _motion_plan(first: int, second: int) -> PlannedProgram:
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
    )


def _surrounding_plan(side: Family, view: int) -> PlannedProgram:
    turn = {
        "behind": "pySpatial.turn_around(pose)",
        "left": "pySpatial.rotate_left(pose, angle=90)",
        "right": "pySpatial.rotate_right(pose, angle=90)",
    }[side]
    source = _SURROUNDING.format(index=view - 1, view=view, name=side, turn=turn)
    return PlannedProgram(
        source=source,
        family=side,
        explanation=f"what is {'behind' if side == 'behind' else 'to the ' + side + ' of'} view {view}: "
        "turn that camera in place and render",
        views=[view],
    )


def plan_program(question: str, num_images: int) -> PlannedProgram:
    """A program for the question; see the module docstring. Raises PlanningError when unplannable."""
    if num_images < 1:
        raise PlanningError("a question needs at least one image")
    text = " ".join(question.split())
    lowered = text.lower()
    # Options ("A. Left B. Right") would look like directions asked about: plan on the stem only.
    stem = re.split(r"(?<![A-Za-z0-9])(?:\(A\)|A[.):])\s", text, maxsplit=1)[0].lower()
    views = view_references(text, num_images)
    _check_views(views, num_images)
    distinct = list(dict.fromkeys(views))
    view = distinct[0] if distinct else 1
    # "If I turn left and walk forward ..." asks about a move not yet made: compose it, render it.
    steps = _pose_steps(stem) if _HYPOTHETICAL.search(stem) else []
    if steps:
        actions = ", then ".join(words for _, words, _ in steps)
        return PlannedProgram(
            source=_turn_and_move_source(view, steps),
            family="turn_and_move",
            explanation=f"from view {view}: {actions}; render before and after the move to compare",
            views=[view],
        )

    if num_images >= 2 and _MOTION_VERB.search(stem):
        if len(distinct) >= 2:
            return _motion_plan(distinct[0], distinct[1])
        if _BETWEEN_VIEWS.search(lowered) or "camera" in stem or re.search(r"\bdid (?:i|you|we)\b", stem):
            return _motion_plan(1, 2)

    sides: list[Family] = [
        side
        for side, pattern in (("behind", _BEHIND), ("left", _LEFT), ("right", _RIGHT))
        if pattern.search(stem)
    ]
    if len(sides) == 1:
        return _surrounding_plan(sides[0], view)
    return PlannedProgram(
        source=_AROUND.format(index=view - 1, view=view),
        family="around",
        explanation=f"no specific family recognized: render left, right and behind of view {view}",
        views=[view],
    )


__all__ = ["Family", "PlannedProgram", "PlanningError", "plan_program", "view_references"]
