"""Regenerate the bundled examples in examples/ (deterministic): the page's gallery and the demo.

Synthetic rooms (shared.synthetic, z up), three rendered views each, with the exact cameras in
example.json and questions whose answers follow from how the cameras were built:
- living_room (the demo's example): the camera stands near the middle of a room, looks at the
  furniture, steps 0.8 m to its right while turning 5 degrees left (inside the "right" sector and
  under the 10-degree "no significant rotation" threshold), then steps right and a little forward;
- corner_turn: steps 0.4 m forward while turning 35 degrees left, then turns a little more;
- step_back: steps 0.7 m straight back, then back and to the right.
And real photos: three views of the Middlebury templeRing set (`--templering`, copied from the
real-data folder, with the dataset's citation): the camera orbits the model along its own image's
vertical, without turning about the scene's up.

Run: .venv/bin/python scripts/make_example.py [--out examples] [--only NAME] [--templering DIR]
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from shared.geometry.poses import move_backward, move_forward, rotate_left  # noqa: E402
from shared.synthetic import default_intrinsic, generate_scene, look_at, render_view  # noqa: E402
from shared.synthetic.photo import save_photo  # noqa: E402
from shared.synthetic.scene import SyntheticScene  # noqa: E402

WIDTH, HEIGHT = 480, 360
FOV_DEG = 60.0
EYE_HEIGHT = 1.4
DEFAULT_OUT = Path(__file__).resolve().parents[1] / "examples"
TEMPLE_VIEWS = (13, 16, 19)  # 23 degrees apart on the ring
TEMPLE_CITATION = (
    "Middlebury multi-view stereo, templeRing: S. M. Seitz, B. Curless, J. Diebel, D. Scharstein and "
    "R. Szeliski, 'A Comparison and Evaluation of Multi-View Stereo Reconstruction Algorithms', CVPR 2006. "
    "https://vision.middlebury.edu/mview/"
)


THUMBNAIL = "gallery/thumbnail.jpg"  # in a sub-folder: a folder of an example's photos is its scene
THUMBNAIL_SIZE = (192, 144)  # the gallery shows 96x72 CSS pixels: sharp on 2x screens


def write_thumbnail(folder: Path, first_photo: str) -> None:
    """A small JPEG of the first photo for the gallery: the photos themselves are ~80-300 KB each."""
    (folder / THUMBNAIL).parent.mkdir(exist_ok=True)
    with Image.open(folder / first_photo) as photo:
        small = photo.convert("RGB")
        small.thumbnail(THUMBNAIL_SIZE)
        small.save(folder / THUMBNAIL, quality=82, optimize=True)


def step_right(extrinsic: np.ndarray, distance: float) -> np.ndarray:
    """Move the camera centre along its own x axis (right), keeping its orientation."""
    moved = extrinsic.copy()
    moved[:, 3] -= np.array([distance, 0.0, 0.0])  # t' = -R (C + d r) = t - d e_x
    return moved


def first_camera(scene: SyntheticScene) -> np.ndarray:
    """0.5 m left of the middle of the free disc, looking across the room, slightly down, toward
    the far wall where the furniture stands."""
    centre = scene.room_centre
    eye = np.array([centre[0] - 0.5, centre[1] - 0.8, EYE_HEIGHT])
    target = np.array([centre[0], scene.room_max[1] - 0.3, 0.3])
    return look_at(eye, target, scene.up)


def living_room_cameras(scene: SyntheticScene) -> list[np.ndarray]:
    first = first_camera(scene)
    second = rotate_left(step_right(first, 0.8), 5.0, up=scene.up)
    third = rotate_left(move_forward(step_right(second, 0.5), 0.3, up=scene.up), 5.0, up=scene.up)
    return [first, second, third]


def corner_turn_cameras(scene: SyntheticScene) -> list[np.ndarray]:
    first = first_camera(scene)
    second = rotate_left(move_forward(first, 0.4, up=scene.up), 35.0, up=scene.up)
    third = rotate_left(move_forward(second, 0.2, up=scene.up), 10.0, up=scene.up)
    return [first, second, third]


def step_back_cameras(scene: SyntheticScene) -> list[np.ndarray]:
    first = move_forward(first_camera(scene), 0.3, up=scene.up)
    second = move_backward(first, 0.7, up=scene.up)
    third = step_right(move_backward(second, 0.3, up=scene.up), 0.4)
    return [first, second, third]


@dataclass(frozen=True)
class SyntheticExample:
    name: str
    title: str
    description: str
    seed: int
    cameras: Callable[[SyntheticScene], list[np.ndarray]]
    questions: list[dict]  # {"text", "expected_answer"} (a letter, or the words a free-form answer has)


OPENING = "These three photos were taken in the same room, in order."
SYNTHETIC = [
    SyntheticExample(
        "living_room",
        "Living room: a step to the right",
        "A procedural room rendered with exact cameras: the camera steps right, then right and forward.",
        3,
        living_room_cameras,
        [
            {
                "text": f"{OPENING} Which way did the camera move from view 1 to view 2? "
                "A. Left B. Forward C. Right D. Backward",
                "expected_answer": "C",
            },
            {
                "text": f"{OPENING} Which way did the camera move from view 1 to view 2?",
                "expected_words": "right",
            },
        ],
    ),
    SyntheticExample(
        "corner_turn",
        "Study: a turn to the left",
        "A procedural room: the camera steps forward while turning about 35 degrees to the left.",
        5,
        corner_turn_cameras,
        [
            {
                "text": f"{OPENING} How did the camera turn from view 1 to view 2? "
                "A. Left B. Right C. It did not turn",
                "expected_answer": "A",
            },
            {"text": f"{OPENING} How did the camera turn from view 1 to view 2?", "expected_words": "left"},
        ],
    ),
    SyntheticExample(
        "step_back",
        "Hall: a step back",
        "A procedural room: the camera steps straight back, then back and to the right.",
        8,
        step_back_cameras,
        [
            {
                "text": f"{OPENING} Which way did the camera move from view 1 to view 2? "
                "A. Forward B. Backward C. Left D. Right",
                "expected_answer": "B",
            },
            {
                "text": f"{OPENING} Which way did the camera move from view 1 to view 2?",
                "expected_words": "backward",
            },
        ],
    ),
]


def write_synthetic(example: SyntheticExample, out: Path) -> None:
    folder = out / example.name
    folder.mkdir(parents=True, exist_ok=True)
    scene = generate_scene(example.seed)
    intrinsic = default_intrinsic(WIDTH, HEIGHT, FOV_DEG)
    cameras = example.cameras(scene)
    names = []
    for index, extrinsic in enumerate(cameras, start=1):
        view = render_view(scene, extrinsic, intrinsic, WIDTH, HEIGHT)
        name = f"view_{index}.png"
        save_photo(folder / name, view.rgb, intrinsic)  # with the EXIF focal, as a camera writes
        names.append(name)
    first = example.questions[0]
    spec = {
        "title": example.title,
        "description": example.description,
        "source": "synthetic",
        # The demo (pyspatial demo) asks the first question and checks its answer.
        "question": first["text"],
        "expected_answer": first["expected_answer"],
        "questions": example.questions,
        "images": names,
        "thumbnail": THUMBNAIL,
        "scene_seed": example.seed,
        "image_size": [WIDTH, HEIGHT],
        "intrinsic": np.round(intrinsic, 6).tolist(),
        "cameras": [np.round(camera, 9).tolist() for camera in cameras],
        "objects": scene.object_names,
    }
    (folder / "example.json").write_text(json.dumps(spec, indent=2) + "\n")
    write_thumbnail(folder, names[0])
    print(f"wrote {len(names)} views and example.json to {folder}")


def write_templering(realdata: Path, out: Path) -> None:
    """Three templeRing photos as they are published, with the citation and their calibration."""
    folder = out / "temple_ring"
    folder.mkdir(parents=True, exist_ok=True)
    source = realdata / "templeRing"
    calibration = {
        line.split()[0]: line.split()[1:]
        for line in (source / "templeR_par.txt").read_text().splitlines()[1:]
    }
    names = []
    for number in TEMPLE_VIEWS:
        name = f"templeR{number:04d}.png"
        shutil.copyfile(source / name, folder / name)
        names.append(name)
    opening = "These three photos of a temple model were taken in order."
    questions = [
        {
            "text": f"{opening} How did the camera turn from view 1 to view 2? "
            "A. Left B. Right C. It did not turn significantly",
            "expected_answer": "C",
        },
        {
            "text": f"{opening} How did the camera turn from view 1 to view 2?",
            "expected_words": "did not turn",
        },
    ]
    spec = {
        "title": "Temple model: real photos",
        "description": "Three real photographs (640x480) of a plaster temple model from the Middlebury "
        "templeRing set, 23 degrees apart on a ring around it; the model lies on its side in the images.",
        "source": "real",
        "citation": TEMPLE_CITATION,
        "note": "Copied unchanged from the templeRing set (images 13, 16 and 19). The expected answers "
        "follow from the set's calibrated cameras (templeR_par.txt, below as K, R, t with x_cam = R X + t): "
        "between these views the camera moves along its own image's vertical and does not turn about "
        "the scene's up.",
        "question": questions[0]["text"],
        "expected_answer": questions[0]["expected_answer"],
        "questions": questions,
        "images": names,
        "thumbnail": THUMBNAIL,
        "calibration": {name: [float(v) for v in calibration[name]] for name in names},
    }
    (folder / "example.json").write_text(json.dumps(spec, indent=2) + "\n")
    write_thumbnail(folder, names[0])
    print(f"copied {len(names)} templeRing photos and wrote example.json to {folder}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--only", help="one synthetic example by name")
    parser.add_argument("--templering", type=Path, help="the real-data folder that holds templeRing/")
    args = parser.parse_args(argv)
    for example in SYNTHETIC:
        if args.only in (None, example.name):
            write_synthetic(example, args.out)
    if args.templering is not None:
        write_templering(args.templering, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
