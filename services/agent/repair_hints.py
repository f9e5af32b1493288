"""Pointed repair hints: per failure class, the one change that fixes it.

A small code model repairs well when told exactly what was wrong ("you used view 1; the question
asks from image 3") and badly when told only that "the program failed" (it sends the same program
back). So each failure class has its own hint, built from the error and the question's intent:

- a forbidden or unavailable name, with the allowed alternative;
- a wrong view or view pair (the asked-view check, services/agent/clue_check.py);
- an answer (letter or option) returned instead of a clue, or a clue the program typed in itself;
- an empty clue;
- a timeout or the CPU limit;
- a tool's error, with the tool's own message.
"""

from __future__ import annotations

import re

from services.agent.clue_check import motion_call
from shared.questions.intent import QuestionIntent

# What to use instead of a name the sandbox does not offer (the validator says "'X' is not available").
ALTERNATIVES = {
    "inv": "use np.linalg.solve(A, b), or pySpatial.relative_pose(E1, E2) for one view's pose from another",
    "pinv": "use np.linalg.solve(A, b), or pySpatial.relative_pose(E1, E2)",
    "print": "return the clue from program(); printed text is not read",
    "open": "the photos are in input_scene.images, and the tools read the scene for you",
    "eval": "write the expression itself",
    "exec": "write the code itself",
    "input": "the question is input_scene.question",
    "getattr": "use the attribute by its name (recon.extrinsics, recon.num_views)",
}
_UNAVAILABLE = re.compile(r"'\.?([A-Za-z_][\w.]*)' is not (?:available|allowed)")
_TOOL_ERROR = re.compile(
    r"program raised \w+: ((?:pySpatial\.)?(describe_camera_motion|synthesize_novel_view|reconstruct"
    r"|rotate_left|rotate_right|move_forward|move_backward|turn_around|camera_center|get_input_image|relative_pose"
    r"|heading_angle|distance_to_point)\b.*?)(?: \(line \d+\))?$",
    re.DOTALL,
)


def _clue_call(intent: QuestionIntent | None) -> str:
    if intent is not None and intent.family == "self_movement":
        return motion_call(intent)
    if intent is not None and intent.asked_view is not None:
        index = intent.asked_view - 1
        return f"views rendered with pySpatial.synthesize_novel_view from recon.extrinsics[{index}]"
    return "the output of a pySpatial tool (a camera-motion sentence or rendered views)"


def _forbidden(error: str) -> list[str]:
    if "imports are not allowed" in error:
        return ["Delete every import line: np, math and pySpatial are already available."]
    hints = []
    for name in dict.fromkeys(_UNAVAILABLE.findall(error)):
        short = name.rsplit(".", 1)[-1]
        instead = ALTERNATIVES.get(short, "use only the numpy functions, math and pySpatial tools listed")
        hints.append(f"`{name}` is not available in the sandbox: {instead}.")
    return hints


def _wrong_view(intent: QuestionIntent | None) -> list[str]:
    if intent is None:
        return ["Use the views the question names."]
    if intent.family == "self_movement" and intent.motion_pair is not None:
        first, second = intent.motion_pair
        return [
            f"The question asks about image {first} -> image {second}. Return {motion_call(intent)}: "
            "it describes that pair directly, consecutive or not."
        ]
    view = intent.asked_view or intent.view
    return [f"The question asks from image {view}: start from pose = recon.extrinsics[{view - 1}]."]


def pointed_hints(error: str, kind: str | None = None, intent: QuestionIntent | None = None) -> list[str]:
    """The hints for one failed run: its failure class first, then the known-mistake hints."""
    hints: list[str] = []
    if kind == "rejected" or _UNAVAILABLE.search(error):
        hints += _forbidden(error)
    if kind in ("wrong_view", "no_motion"):
        hints += _wrong_view(intent)
    if kind in ("answer_letter", "not_evidence"):
        hints.append(
            f"You returned an answer, not a clue. Return {_clue_call(intent)}; another model reads it "
            "and chooses the option."
        )
    if kind == "empty_clue":
        hints.append(f"Your program returned an empty clue. Return {_clue_call(intent)}.")
    if kind == "unread_images":
        text_call = (
            motion_call(intent)
            if intent is not None and intent.family == "self_movement"
            else "the text a pySpatial tool returns (describe_camera_motion's sentence)"
        )
        hints.append(f"Nothing here can look at images: the answer is read from text. Return {text_call}.")
    if kind in ("timeout", "cpu"):
        hints.append(
            "The program ran out of time: no loops over pixels or points; call each tool once and "
            "return its output."
        )
    tool = _TOOL_ERROR.search(error)
    if tool:
        hints.append(f"The tool {tool.group(2)} said: {tool.group(1).strip()} Change the call as it says.")
    return hints


__all__ = ["ALTERNATIVES", "pointed_hints"]
