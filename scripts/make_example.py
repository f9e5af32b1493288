"""Regenerate examples/living_room/: three rendered views and example.json (deterministic).

The camera stands near the middle of a procedural room (shared.synthetic, z up), looks at the
furniture, then steps 0.8 m to its right while turning 5 degrees left (well inside the "right"
sector and under the 10-degree "no significant rotation" threshold), then steps again to the right
and a little forward. The question asks which way it moved from view 1 to view 2: "right".

Run: .venv/bin/python scripts/make_example.py [--out examples/living_room]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from shared.geometry.poses import move_forward, rotate_left  # noqa: E402
from shared.synthetic import default_intrinsic, generate_scene, look_at, render_view  # noqa: E402
from shared.synthetic.photo import save_photo  # noqa: E402

SCENE_SEED = 3
WIDTH, HEIGHT = 480, 360
FOV_DEG = 60.0
EYE_HEIGHT = 1.4
SIDE_STEP_M = 0.8
TURN_DEG = 5.0
QUESTION = (
    "These three photos were taken in the same room, in order. "
    "Which way did the camera move from view 1 to view 2? "
    "A. Left B. Forward C. Right D. Backward"
)
EXPECTED_ANSWER = "C"
DEFAULT_OUT = Path(__file__).resolve().parents[1] / "examples" / "living_room"


def step_right(extrinsic: np.ndarray, distance: float) -> np.ndarray:
    """Move the camera centre along its own x axis (right), keeping its orientation."""
    moved = extrinsic.copy()
    moved[:, 3] -= np.array([distance, 0.0, 0.0])  # t' = -R (C + d r) = t - d e_x
    return moved


def example_cameras() -> list[np.ndarray]:
    """The three 3x4 camera-from-world poses, built from the pose tools so the motion is exact."""
    scene = generate_scene(SCENE_SEED)
    centre = scene.room_centre
    # Start 0.5 m left of the middle of the free disc and look across the room, slightly down,
    # toward the far wall where the table, the box and the ball stand.
    eye = np.array([centre[0] - 0.5, centre[1] - 0.8, EYE_HEIGHT])
    target = np.array([centre[0], scene.room_max[1] - 0.3, 0.3])
    first = look_at(eye, target, scene.up)
    second = rotate_left(step_right(first, SIDE_STEP_M), TURN_DEG, up=scene.up)
    third = rotate_left(move_forward(step_right(second, 0.5), 0.3, up=scene.up), TURN_DEG, up=scene.up)
    return [first, second, third]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    out = parser.parse_args(argv).out
    out.mkdir(parents=True, exist_ok=True)

    scene = generate_scene(SCENE_SEED)
    intrinsic = default_intrinsic(WIDTH, HEIGHT, FOV_DEG)
    cameras = example_cameras()
    names = []
    for index, extrinsic in enumerate(cameras, start=1):
        view = render_view(scene, extrinsic, intrinsic, WIDTH, HEIGHT)
        name = f"view_{index}.png"
        save_photo(out / name, view.rgb, intrinsic)  # with the EXIF focal, as a camera writes
        names.append(name)

    example = {
        "question": QUESTION,
        "expected_answer": EXPECTED_ANSWER,
        "images": names,
        "scene_seed": SCENE_SEED,
        "image_size": [WIDTH, HEIGHT],
        "intrinsic": np.round(intrinsic, 6).tolist(),
        "cameras": [np.round(camera, 9).tolist() for camera in cameras],
        "objects": scene.object_names,
    }
    (out / "example.json").write_text(json.dumps(example, indent=2) + "\n")
    print(f"wrote {len(names)} views and example.json to {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
