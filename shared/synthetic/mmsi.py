"""MMSI-Bench-style questions on synthetic rooms, with exact answers, as rows of MMSI's parquet schema.

Each row is what `pyspatial eval mmsi` reads: `id`, `images` (PNG bytes), `question_type` (MMSI's
type names), `question` with "Options: A: ..., B: ..." inside, `answer` (a letter), `thought`,
`difficulty`, `mean_normed_duration_seconds`. The answers come from the exact cameras and objects:
- "Motion (Cam.)": a second photo from the first camera moved or rotated one way on purpose (a step
  right / left / up / down / forward / backward, a turn, a tilt, a roll, or none); the words are the
  ones shared.geometry.camera_motion says for that pair, so every motion word has an exact check;
- "Positional Relationship (Cam.–Cam.)": where the second photo's camera stands, seen from the first;
- "Positional Relationship (Cam.–Obj.)": where an object is, seen from the first photo's camera;
- "Positional Relationship (Obj.–Obj.)": one object's side of another, seen from the first camera,
  the two objects each named with the photo it is in;
- "Attribute (Meas.)": the distance in metres between two objects' centres (posed RGB-D scenes).
Only clear cases are asked (at least 30 degrees from a sector boundary), so no answer is a coin toss.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from shared.geometry.camera_motion import describe_camera_motion
from shared.synthetic.photo import photo_bytes
from shared.synthetic.render import default_intrinsic, render_view
from shared.synthetic.scene import SyntheticScene, generate_scene

MOTION_CAM = "Motion (Cam.)"
CAM_CAM = "Positional Relationship (Cam.–Cam.)"
CAM_OBJ = "Positional Relationship (Cam.–Obj.)"
OBJ_OBJ = "Positional Relationship (Obj.–Obj.)"
MEASUREMENT = "Attribute (Meas.)"
TYPES = (MOTION_CAM, CAM_CAM, CAM_OBJ, OBJ_OBJ, MEASUREMENT)
LETTERS = "ABCD"
_CLEAR_DEG = 15.0  # at least this far from a 45-degree sector boundary

# Motions made on purpose: (step in the first camera's axes x right, y down, z forward; rotation of
# camera 2's axes in camera 1's coordinates as (axis, degrees)), and the option people would write.
MOTIONS = {
    "right": ((0.4, 0.0, 0.0), None, "It moved to the right"),
    "left": ((-0.4, 0.0, 0.0), None, "It moved to the left"),
    "up": ((0.0, -0.3, 0.0), None, "It moved up"),
    "down": ((0.0, 0.3, 0.0), None, "It moved down"),
    "forward": ((0.0, 0.0, 0.4), None, "It moved forward"),
    "backward": ((0.0, 0.0, -0.4), None, "It moved backward"),
    "turn left": ((0.0, 0.0, 0.0), ("y", -30.0), "It panned left"),
    "turn right": ((0.0, 0.0, 0.0), ("y", 30.0), "It panned right"),
    "tilt up": ((0.0, 0.0, 0.0), ("x", 15.0), "It tilted upward"),
    "tilt down": ((0.0, 0.0, 0.0), ("x", -15.0), "It tilted downward"),
    "roll clockwise": ((0.0, 0.0, 0.0), ("z", 20.0), "It rolled clockwise"),
    "roll counterclockwise": ((0.0, 0.0, 0.0), ("z", -20.0), "It rolled counterclockwise"),
    "still": ((0.0, 0.0, 0.0), None, "It stayed still"),
}


def _axis_rotation(axis: str, degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def moved_camera(first: np.ndarray, motion: str) -> np.ndarray:
    """Camera 2 = camera 1 moved in its own axes and rotated as `MOTIONS[motion]` says."""
    step, rotation, _ = MOTIONS[motion]
    r1, center = first[:3, :3], -first[:3, :3].T @ first[:3, 3]
    axes = np.eye(3) if rotation is None else _axis_rotation(*rotation)
    r2 = axes.T @ r1
    c2 = center + r1.T @ np.asarray(step)
    return np.hstack([r2, (-r2 @ c2)[:, None]])


def motion_word(first: np.ndarray, second: np.ndarray) -> str:
    """The MOTIONS key shared camera motion says for the pair (image frame), or '' when none fits."""
    m = describe_camera_motion(np.stack([first, second]), scene_scale=4.0, up=np.array([0.0, 0.0, 1.0]))[0]
    image = m.image
    said = [
        (m.still, "still"),
        (
            image.direction in ("right", "left", "forward", "backward") and not image.vertical_direction,
            image.direction,
        ),
        (
            image.direction == "no significant movement" and image.vertical_direction is not None,
            str(image.vertical_direction),
        ),
        ("turned left" in image.phrase, "turn left"),
        ("turned right" in image.phrase, "turn right"),
        ("tilted up" in image.phrase, "tilt up"),
        ("tilted down" in image.phrase, "tilt down"),
        ("rolled clockwise" in image.phrase, "roll clockwise"),
        ("rolled counterclockwise" in image.phrase, "roll counterclockwise"),
    ]
    words = [word for holds, word in said if holds]
    return words[0] if len(words) == 1 else ""


def _side(vector_in_camera: np.ndarray) -> str | None:
    """'left', 'right', 'in front', 'behind' of a camera-frame vector, when clearly one of them."""
    angle = float(np.degrees(np.arctan2(vector_in_camera[0], vector_in_camera[2])))
    for name, centre in (("in front", 0.0), ("right", 90.0), ("behind", 180.0), ("left", -90.0)):
        if abs((angle - centre + 180.0) % 360.0 - 180.0) <= 45.0 - _CLEAR_DEG:
            return name
    return None


def _options(rng: np.random.Generator, answer: str, pool: list[str]) -> tuple[str, str]:
    others = [p for p in pool if p != answer]
    chosen = [answer, *rng.choice(others, size=3, replace=False).tolist()]
    order = rng.permutation(4)
    texts = [chosen[i] for i in order]
    letter = LETTERS[int(np.where(order == 0)[0][0])]
    return ", ".join(f"{LETTERS[i]}: {t}" for i, t in enumerate(texts)), letter


def _row(row_id: str, kind: str, images: list[bytes], question: str, options: str, letter: str, thought: str):
    return {
        "id": row_id,
        "images": images,
        "question_type": kind,
        "question": f"{question}\nOptions: {options}",
        "answer": letter,
        "thought": thought,
        "difficulty": "easy",
        "mean_normed_duration_seconds": 10.0,
    }


def _render(scene: SyntheticScene, pose: np.ndarray, size: tuple[int, int]) -> bytes:
    intrinsic = default_intrinsic(*size)
    return photo_bytes(render_view(scene, pose, intrinsic, *size).rgb, intrinsic)


def _camera(scene: SyntheticScene, rng: np.random.Generator) -> np.ndarray:
    """A level camera at 1.5 m in the room's middle third, looking at a random object."""
    low, high = scene.room_min[:2], scene.room_max[:2]
    center = np.array([*rng.uniform(low + (high - low) / 3, high - (high - low) / 3), 1.5])
    target = scene.object_centres[int(rng.integers(len(scene.object_names)))].copy()
    forward = target - center
    forward[2] = 0.0
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.array([0.0, 0.0, 1.0]))
    rotation = np.stack([right, np.cross(forward, right), forward])
    return np.hstack([rotation, (-rotation @ center)[:, None]])


def _motion_row(scene, first, motion, rng, size, row_id):
    second = moved_camera(first, motion)
    if motion_word(first, second) != motion:  # the words must say exactly what was done
        raise AssertionError(f"camera motion says {motion_word(first, second)!r} for {motion!r}")
    options, letter = _options(rng, MOTIONS[motion][2], [m[2] for m in MOTIONS.values()])
    question = "How did the camera move from the first image to the second image?"
    thought = f"The second photo was taken after the camera {motion}."
    return _row(
        row_id,
        MOTION_CAM,
        [_render(scene, p, size) for p in (first, second)],
        question,
        options,
        letter,
        thought,
    )


def _position_rows(scene, first, rng, size, prefix) -> Iterator[dict]:
    second = _camera(scene, rng)
    images = [_render(scene, p, size) for p in (first, second)]
    r1, t1 = first[:3, :3], first[:3, 3]
    sides = ["left", "right", "in front", "behind"]
    where = _side(r1 @ (-second[:3, :3].T @ second[:3, 3]) + t1)
    if where is not None:
        options, letter = _options(rng, where, sides)
        question = "Where was the camera of the second image, seen from the camera of the first image?"
        yield _row(f"{prefix}_camcam", CAM_CAM, images, question, options, letter, f"It was {where}.")
    names, centres = scene.object_names, scene.object_centres
    index = int(rng.integers(len(names)))
    where = _side(r1 @ centres[index] + t1)
    if where is not None:
        options, letter = _options(rng, where, sides)
        question = f"Where is the {names[index]}, seen from the camera of the first image?"
        yield _row(f"{prefix}_camobj", CAM_OBJ, images, question, options, letter, f"It is {where}.")
    a, b = rng.choice(len(names), size=2, replace=False)
    where = _side(r1 @ (centres[a] - centres[b]))
    if where is not None and names[a] != names[b]:
        options, letter = _options(rng, where, sides)
        question = (
            f"Seen from the camera of the first image, where is the {names[a]} relative to the {names[b]}?"
        )
        yield _row(f"{prefix}_objobj", OBJ_OBJ, images, question, options, letter, f"It is {where} of it.")
    if names[a] != names[b]:
        metres = float(np.linalg.norm(centres[a] - centres[b]))
        values = [f"{metres * k:.1f} m" for k in (1.0, 0.5, 1.7, 2.6)]
        options, letter = _options(rng, values[0], values)
        question = f"How far apart are the centres of the {names[a]} and the {names[b]}?"
        yield _row(f"{prefix}_meas", MEASUREMENT, images, question, options, letter, f"{metres:.2f} m.")


def _scene(rng: np.random.Generator) -> SyntheticScene:
    for _ in range(50):
        try:
            return generate_scene(int(rng.integers(2**31)))
        except ValueError:
            continue  # the furniture did not fit this room; draw another
    raise RuntimeError("no synthetic room could be laid out in 50 tries")


def mmsi_rows(seed: int, scenes: int, size: tuple[int, int] = (160, 120), motions: list[str] | None = None):
    """Rows of MMSI's schema: per scene one motion question (cycling through MOTIONS) and the
    positional and measurement questions its cameras and objects clearly answer."""
    kinds = motions or list(MOTIONS)
    rows = []
    for index in range(scenes):
        rng = np.random.default_rng([seed, index])
        scene = _scene(rng)
        first = _camera(scene, rng)
        motion = kinds[index % len(kinds)]
        rows.append(_motion_row(scene, first, motion, rng, size, f"syn{index:04d}_motion"))
        rows.extend(_position_rows(scene, first, rng, size, f"syn{index:04d}"))
    return rows


def write_parquet(rows: list[dict], path, row_group_size: int = 8) -> None:
    """The rows as a parquet file with MMSI-Bench's column types (images: list of binary)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = pa.schema(
        [
            ("id", pa.string()),
            ("images", pa.list_(pa.binary())),
            ("question_type", pa.string()),
            ("question", pa.string()),
            ("answer", pa.string()),
            ("thought", pa.string()),
            ("difficulty", pa.string()),
            ("mean_normed_duration_seconds", pa.float64()),
        ]
    )
    pq.write_table(pa.Table.from_pylist(rows, schema=schema), path, row_group_size=row_group_size)
