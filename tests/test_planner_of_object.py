"""The planner on "behind / left / right of <object>": about that object seen from the asked view.

Exact synthetic cases: scenes and cameras of shared/synthetic, where which object lies behind (or
to the left of) another, seen from a view, follows from the geometry. The planner's program runs in
the real sandbox against the exact renderer, and the objects its clue images show are read from the
renderer's object ids. Reading "behind the X" as "behind me" (the camera turned around) fails here:
it shows the objects behind the camera and not the one behind X.
"""

from __future__ import annotations

import io
from functools import lru_cache

import numpy as np
import pytest
from PIL import Image

from services.agent.planner import plan_intent
from services.agent.sandbox import run_program
from shared.questions.intent import parse_question
from shared.synthetic import default_intrinsic, render_view
from shared.synthetic.dataset import _scene_and_rig
from tests.test_sandbox import LIMITS

WIDTH, HEIGHT = 96, 72
INTRINSIC = default_intrinsic(WIDTH, HEIGHT)
MIN_PIXELS = 4  # an object "is in" a render when it covers at least this many pixels


class ExactTools:
    """The sandbox's tools on an exact synthetic scene: its cameras, and renders by ray casting."""

    def __init__(self, scene, extrinsics: np.ndarray) -> None:
        self.scene, self.extrinsics = scene, extrinsics
        self.rendered: list[np.ndarray] = []

    def reconstruct(self) -> dict:
        count = len(self.extrinsics)
        return {
            "extrinsics": [e.tolist() for e in self.extrinsics],
            "intrinsics": [INTRINSIC.tolist()] * count,
            "image_sizes": [[WIDTH, HEIGHT]] * count,
            "registered": [True] * count,
            "up": [0.0, 0.0, 1.0],
        }

    def describe_camera_motion(self, pair=None) -> list[str]:
        return []

    def synthesize_novel_view(self, extrinsic, width: int, height: int) -> bytes:
        self.rendered.append(np.asarray(extrinsic, dtype=float))
        buffer = io.BytesIO()
        Image.fromarray(render_view(self.scene, np.asarray(extrinsic), INTRINSIC, WIDTH, HEIGHT).rgb).save(
            buffer, format="PNG"
        )
        return buffer.getvalue()

    def input_image(self, index: int) -> bytes:
        return self.synthesize_novel_view(self.extrinsics[index], WIDTH, HEIGHT)


def _visible(scene, extrinsic: np.ndarray) -> set[int]:
    ids, counts = np.unique(
        render_view(scene, extrinsic, INTRINSIC, WIDTH, HEIGHT).object_ids, return_counts=True
    )
    return {int(i) for i, n in zip(ids, counts, strict=True) if i >= 0 and n >= MIN_PIXELS}


def _bearing_and_depth(extrinsic: np.ndarray, point: np.ndarray) -> tuple[float, float]:
    local = extrinsic[:3, :3] @ point + extrinsic[:3, 3]
    return float(np.degrees(np.arctan2(local[0], local[2]))), float(np.hypot(local[0], local[2]))


@lru_cache(maxsize=1)
def _cases() -> dict[str, tuple]:
    """The first exact case of each kind: (scene, extrinsics, view index, anchor id, answer id, other ids)."""
    found: dict[str, tuple] = {}
    for index in range(9):  # dataset seed 1: each kind has a case among these scenes
        scene, rig, _ = _scene_and_rig(1, index, ("among", "around")[index % 2])
        centres = scene.object_centres
        for k, extrinsic in enumerate(rig.extrinsics):
            seen = _visible(scene, extrinsic)
            where = {i: _bearing_and_depth(extrinsic, c) for i, c in enumerate(centres)}
            behind_camera = {i for i, (b, _) in where.items() if abs(b) > 150}
            for anchor in seen:
                bearing, depth = where[anchor]
                if abs(bearing) > 20:
                    continue  # the view looks at the anchor
                for other in seen - {anchor}:
                    b, d = where[other]
                    if "behind" not in found and abs(b - bearing) < 12 and d > depth + 0.3:
                        found["behind"] = (scene, rig.extrinsics, k, anchor, other, behind_camera)
                    side = "left" if b < bearing else "right"
                    if side not in found and 10 < abs(b - bearing) < 30:
                        found[side] = (scene, rig.extrinsics, k, anchor, other, behind_camera)
            if len(found) == 3:
                return found
    return found


@pytest.mark.parametrize("side", ["behind", "left", "right"])
def test_of_object_is_about_the_object_seen_from_the_asked_view(side: str) -> None:
    assert side in _cases(), f"no exact '{side}' case in the synthetic scenes searched"
    scene, extrinsics, view, anchor, answer, behind_camera = _cases()[side]
    name = scene.object_names[anchor]
    ask = {"behind": f"what is behind the {name}", "left": f"what is to the left of the {name}",
           "right": f"what is to the right of the {name}"}[side]  # fmt: skip
    intent = parse_question(f"From image {view + 1}, {ask}? A. one B. two", len(extrinsics))
    assert (intent.direction, intent.target_object, intent.asked_view) == (side, f"the {name}", view + 1)
    tools = ExactTools(scene, extrinsics)
    result = run_program(
        plan_intent(intent, len(extrinsics)).source, intent.text, len(extrinsics), tools, LIMITS
    )
    assert result.ok, result.error
    shown = [_visible(scene, pose) for pose in tools.rendered]
    assert shown and anchor in shown[0]  # the asked view, which looks at the object, comes first
    assert any(answer in objects for objects in shown)  # and what lies behind / beside it is shown
    if side == "behind":  # about the object: never the camera turned around
        assert all(anchor in objects for objects in shown)
        assert not any(objects & (behind_camera - {anchor, answer}) for objects in shown)
    else:  # the view and that view turned toward the side
        assert len(shown) == 2 and np.allclose(tools.rendered[0], extrinsics[view][:3, :4])
