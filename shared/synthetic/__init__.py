"""Procedural indoor scenes rendered on CPU with exact cameras, depth and object ids.

World frame is z-up (floor at z = 0); cameras are OpenCV camera-from-world extrinsics.
"""

from shared.synthetic.cameras import SETTINGS, CameraRig, among_rig, around_rig, make_rig, rotation_rig
from shared.synthetic.dataset import JSONL_NAME, make_dataset
from shared.synthetic.geometry import MOTION_DIRECTIONS, bearing_deg, camera_centre, turn_deg
from shared.synthetic.questions import Question, questions_for_rig
from shared.synthetic.render import RenderedView, default_intrinsic, look_at, render_view
from shared.synthetic.scene import ROOM_OBJECT_ID, SceneObject, SyntheticScene, generate_scene

__all__ = [
    "JSONL_NAME",
    "MOTION_DIRECTIONS",
    "ROOM_OBJECT_ID",
    "SETTINGS",
    "CameraRig",
    "Question",
    "RenderedView",
    "SceneObject",
    "SyntheticScene",
    "among_rig",
    "around_rig",
    "bearing_deg",
    "camera_centre",
    "default_intrinsic",
    "generate_scene",
    "look_at",
    "make_dataset",
    "make_rig",
    "questions_for_rig",
    "render_view",
    "rotation_rig",
    "turn_deg",
]
