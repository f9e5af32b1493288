"""Write a MindCube-style benchmark of synthetic scenes with exact cameras and depth.

Layout under ``out_dir``::

    questions.jsonl                  one MindCube-schema record per question (meta_info a list;
                                     ``pyspatial_scene``: scene file, views, options, facts)
    images/scene_0003/view0.png      RGB renders (paths in the JSONL are relative to out_dir)
    scenes/scene_0003.npz            extrinsics (V,3,4), intrinsics (V,3,3), depths (V,H,W),
                                     object_ids (V,H,W), image_sizes, objects, room, up, seed

Scene i uses the setting SETTINGS[i % 3], so any three consecutive scenes cover all settings.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from shared.synthetic.cameras import SETTINGS, CameraRig, make_rig
from shared.synthetic.photo import save_photo
from shared.synthetic.questions import Question, questions_for_rig
from shared.synthetic.render import default_intrinsic, render_view
from shared.synthetic.scene import SyntheticScene, generate_scene

JSONL_NAME = "questions.jsonl"
_MAX_SCENE_ATTEMPTS = 50


def _scene_and_rig(seed: int, index: int, setting: str) -> tuple[SyntheticScene, CameraRig, int]:
    """The first derived scene seed whose layout admits a rig for the setting."""
    for attempt in range(_MAX_SCENE_ATTEMPTS):
        scene_seed = int(np.random.SeedSequence([seed, index, attempt]).generate_state(1)[0])
        try:
            scene = generate_scene(scene_seed)
        except ValueError:
            continue  # furniture did not fit this room; draw another
        rig = make_rig(setting, scene, np.random.default_rng(scene_seed))
        if rig is not None:
            return scene, rig, scene_seed
    raise RuntimeError(f"no {setting} rig found for scene {index} after {_MAX_SCENE_ATTEMPTS} attempts")


def _record(
    question: Question, number: int, index: int, rig: CameraRig, image_paths: list[str], scene_file: str
) -> dict:
    return {
        "id": f"{rig.setting}_{index:04d}_{question.family}_{number:02d}",
        "question": question.text,
        "gt_answer": question.answer_letter,
        "images": [image_paths[v] for v in question.views],
        "category": [rig.setting, question.family],
        "type": question.family,
        # MindCube's meta_info is a list; the exact scene (for posed-rgbd) travels beside it.
        "meta_info": [[rig.view_names[v] for v in question.views]],
        "pyspatial_scene": {
            "scene_file": scene_file,
            "setting": rig.setting,
            "views": [rig.view_names[v] for v in question.views],
            "view_indices": question.views,
            "options": question.options,
            "rig": rig.facts,
            "facts": question.facts,
        },
    }


def make_dataset(
    out_dir: str | Path, num_scenes: int, seed: int, width: int = 320, height: int = 240
) -> Path:
    """Render ``num_scenes`` scenes and their questions; returns the path of the JSONL file."""
    out_dir = Path(out_dir)
    (out_dir / "scenes").mkdir(parents=True, exist_ok=True)
    intrinsic = default_intrinsic(width, height)
    records: list[dict] = []
    for index in range(num_scenes):
        setting = SETTINGS[index % len(SETTINGS)]
        scene, rig, scene_seed = _scene_and_rig(seed, index, setting)
        views = [render_view(scene, e, intrinsic, width, height) for e in rig.extrinsics]

        image_dir = out_dir / "images" / f"scene_{index:04d}"
        image_dir.mkdir(parents=True, exist_ok=True)
        image_paths = []
        for name, view in zip(rig.view_names, views, strict=True):
            save_photo(image_dir / f"{name}.png", view.rgb, intrinsic)
            image_paths.append(f"images/scene_{index:04d}/{name}.png")

        scene_file = f"scenes/scene_{index:04d}.npz"
        np.savez_compressed(
            out_dir / scene_file,
            extrinsics=rig.extrinsics,
            intrinsics=np.repeat(intrinsic[None], len(views), axis=0),
            depths=np.stack([v.depth for v in views]),
            object_ids=np.stack([v.object_ids for v in views]).astype(np.int16),
            image_sizes=np.tile([width, height], (len(views), 1)).astype(np.int32),
            object_names=np.array(scene.object_names),
            object_centres=scene.object_centres,
            object_sizes=scene.object_sizes,
            room_min=scene.room_min,
            room_max=scene.room_max,
            up=scene.up,
            scene_seed=np.int64(scene_seed),
            setting=np.array(setting),
            view_names=np.array(rig.view_names),
        )
        questions = questions_for_rig(scene, rig, np.random.default_rng([seed, index]))
        for number, question in enumerate(questions):
            records.append(_record(question, number, index, rig, image_paths, scene_file))

    jsonl = out_dir / JSONL_NAME
    with jsonl.open("w", encoding="utf-8") as handle:
        for record in records:
            handle.write(json.dumps(record) + "\n")
    return jsonl
