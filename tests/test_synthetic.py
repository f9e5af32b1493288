"""Synthetic scenes: exact depth and ids, texture good enough for matching, and answers that the
geometry supports (recomputed here from the saved cameras, independently of questions.py)."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from shared.geometry.camera_motion import DIRECTIONS as CAMERA_MOTION_DIRECTIONS
from shared.synthetic import (
    ROOM_OBJECT_ID,
    default_intrinsic,
    generate_scene,
    look_at,
    make_dataset,
    render_view,
    rotation_rig,
)

WIDTH, HEIGHT = 320, 240
K = default_intrinsic(WIDTH, HEIGHT)


def _centre(extrinsic: np.ndarray) -> np.ndarray:
    return -extrinsic[:, :3].T @ extrinsic[:, 3]


def _backproject(view, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World points under integer pixels (N, 2) from the rendered depth, and which had depth."""
    depth = view.depth[pixels[:, 1], pixels[:, 0]]
    rays = np.c_[pixels, np.ones(len(pixels))] @ np.linalg.inv(view.intrinsic).T
    rotation, translation = view.extrinsic[:, :3], view.extrinsic[:, 3]
    return (rays * depth[:, None] - translation) @ rotation, depth > 0


def _eye_at_room_centre(scene) -> np.ndarray:
    return np.array([*scene.room_centre[:2], 1.5])


def test_scene_and_render_are_deterministic_for_a_seed():
    first, again, other = generate_scene(11), generate_scene(11), generate_scene(12)
    assert first.object_names == again.object_names
    np.testing.assert_array_equal(first.vertices, again.vertices)
    np.testing.assert_array_equal(first.triangle_object_ids, again.triangle_object_ids)
    assert not np.array_equal(first.room_max, other.room_max)
    eye = _eye_at_room_centre(first)
    extrinsic = look_at(eye, eye + [1.0, 0.3, -0.2])
    a, b = render_view(first, extrinsic, K, WIDTH, HEIGHT), render_view(again, extrinsic, K, WIDTH, HEIGHT)
    np.testing.assert_array_equal(a.rgb, b.rgb)
    np.testing.assert_array_equal(a.depth, b.depth)


def test_scene_objects_are_distinct_and_inside_the_room():
    for seed in range(5):
        scene = generate_scene(seed)
        assert 4 <= len(scene.objects) <= 8
        assert len(set(scene.object_names)) == len(scene.objects)
        for obj in scene.objects:
            assert np.all(obj.centre - obj.size / 2 >= scene.room_min - 1e-9)
            assert np.all(obj.centre + obj.size / 2 <= scene.room_max + 1e-9)
    assert len(generate_scene(3, num_objects=6).objects) == 6


def test_look_at_follows_the_opencv_convention():
    eye, target = np.array([1.0, 2.0, 1.5]), np.array([4.0, 2.5, 1.0])
    extrinsic = look_at(eye, target)
    rotation = extrinsic[:, :3]
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(_centre(extrinsic), eye, atol=1e-12)
    in_camera = rotation @ target + extrinsic[:, 3]
    assert in_camera[0] == pytest.approx(0, abs=1e-12) and in_camera[1] == pytest.approx(0, abs=1e-12)
    assert in_camera[2] > 0
    above = rotation @ (eye + [0, 0, 1.0]) + extrinsic[:, 3]
    assert above[1] < 0, "world up must point to image up (-y)"
    assert K[0, 0] == pytest.approx((WIDTH / 2) / np.tan(np.radians(30)))


def _analytic_room_depth(scene, extrinsic: np.ndarray) -> np.ndarray:
    """z-depth of the first room plane each pixel ray meets inside its rectangle (0 = none)."""
    u, v = np.meshgrid(np.arange(WIDTH), np.arange(HEIGHT))
    rays_cam = np.stack([u, v, np.ones_like(u)], -1).reshape(-1, 3) @ np.linalg.inv(K).T
    rays = rays_cam @ extrinsic[:, :3]  # world directions whose camera z component is 1
    origin = _centre(extrinsic)
    best = np.full(len(rays), np.inf)
    low, high = scene.room_min, scene.room_max
    planes = [(axis, low[axis]) for axis in range(3)] + [(axis, high[axis]) for axis in range(2)]
    if scene.has_ceiling:
        planes.append((2, high[2]))
    for axis, offset in planes:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (offset - origin[axis]) / rays[:, axis]
        points = origin + rays * t[:, None]
        others = [a for a in range(3) if a != axis]
        inside = np.all(
            (points[:, others] >= low[others] - 1e-6) & (points[:, others] <= high[others] + 1e-6), 1
        )
        ok = (t > 0) & inside
        best[ok] = np.minimum(best[ok], t[ok])
    return np.where(np.isfinite(best), best, 0.0).reshape(HEIGHT, WIDTH)


@pytest.mark.parametrize("seed", [2, 5])
def test_depth_of_room_surfaces_is_exact(seed):
    scene = generate_scene(seed)
    eye = _eye_at_room_centre(scene)
    # Straight at the +x wall: every wall pixel sees the same z-depth, the wall's distance.
    facing_wall = look_at(eye, eye + [1.0, 0.0, 0.0])
    view = render_view(scene, facing_wall, K, WIDTH, HEIGHT)
    wall_distance = scene.room_max[0] - eye[0]
    u, v = np.meshgrid(np.arange(WIDTH), np.arange(HEIGHT))
    # Where each pixel ray meets the wall's plane (camera right is world -y, camera down is -z).
    wall_y = eye[1] - (u - K[0, 2]) / K[0, 0] * wall_distance
    wall_z = eye[2] - (v - K[1, 2]) / K[1, 1] * wall_distance
    on_wall = (view.object_ids == ROOM_OBJECT_ID) & (wall_y > 0.01) & (wall_y < scene.room_max[1] - 0.01)
    on_wall &= (wall_z > 0.01) & (wall_z < scene.room_max[2] - 0.01)
    assert on_wall.sum() > 2000
    np.testing.assert_allclose(view.depth[on_wall], wall_distance, atol=1e-4)
    # A tilted, turned camera: all room pixels (floor, walls, ceiling) match ray-plane geometry.
    tilted = look_at(eye, eye + [0.6, -0.8, -0.35])
    view = render_view(scene, tilted, K, WIDTH, HEIGHT)
    expected = _analytic_room_depth(scene, tilted)
    room = view.object_ids == ROOM_OBJECT_ID
    assert room.sum() > 5000
    np.testing.assert_allclose(view.depth[room], expected[room], atol=1e-4)


def test_object_ids_mark_the_object_in_view():
    scene = generate_scene(4, num_objects=1)
    obj = scene.objects[0]
    eye = _eye_at_room_centre(scene)
    view = render_view(scene, look_at(eye, obj.centre), K, WIDTH, HEIGHT)
    centre_pixel = np.rint(K[:2, 2]).astype(int)
    assert view.object_ids[centre_pixel[1], centre_pixel[0]] == 0
    v, u = np.nonzero(view.object_ids == 0)
    assert len(u) > 200
    points, has_depth = _backproject(view, np.c_[u, v])
    assert has_depth.all()
    assert np.all(np.abs(points - obj.centre) <= obj.size / 2 + 1e-3), "object pixels must lie on it"
    assert set(np.unique(view.object_ids)) <= {ROOM_OBJECT_ID, 0}


def test_textures_give_many_orb_keypoints():
    orb = cv2.ORB_create(nfeatures=2000)
    for seed in (0, 1, 2):
        scene = generate_scene(seed)
        for extrinsic in rotation_rig(scene, np.random.default_rng(seed)).extrinsics:
            gray = cv2.cvtColor(render_view(scene, extrinsic, K, WIDTH, HEIGHT).rgb, cv2.COLOR_RGB2GRAY)
            assert len(orb.detect(gray)) >= 200


def test_two_views_have_many_geometrically_correct_matches():
    scene = generate_scene(8)
    eye = _eye_at_room_centre(scene)
    first = look_at(eye, eye + [1.0, 0.0, -0.2])
    second_eye = eye + [0.0, -0.4, 0.0]  # a step to the right of the first camera
    second = look_at(second_eye, second_eye + [np.cos(0.2), -np.sin(0.2), -0.2])
    view_1 = render_view(scene, first, K, WIDTH, HEIGHT)
    view_2 = render_view(scene, second, K, WIDTH, HEIGHT)
    orb = cv2.ORB_create(nfeatures=1500)
    keys_1, desc_1 = orb.detectAndCompute(cv2.cvtColor(view_1.rgb, cv2.COLOR_RGB2GRAY), None)
    keys_2, desc_2 = orb.detectAndCompute(cv2.cvtColor(view_2.rgb, cv2.COLOR_RGB2GRAY), None)
    matches = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(desc_1, desc_2)
    pixels_1 = np.array([keys_1[m.queryIdx].pt for m in matches])
    pixels_2 = np.array([keys_2[m.trainIdx].pt for m in matches])
    points, has_depth = _backproject(view_1, np.rint(pixels_1).astype(int))
    in_second = points @ second[:, :3].T + second[:, 3]
    projected = in_second @ K.T
    projected = projected[:, :2] / projected[:, 2:]
    correct = has_depth & (np.linalg.norm(projected - pixels_2, axis=1) < 3.0)
    assert correct.sum() >= 100
    assert correct.mean() >= 0.5


def test_render_is_fast():
    scene = generate_scene(1)
    eye = _eye_at_room_centre(scene)
    extrinsic = look_at(eye, eye + [0.0, 1.0, -0.2])
    render_view(scene, extrinsic, K, WIDTH, HEIGHT)  # builds the acceleration structure once
    start = time.perf_counter()
    render_view(scene, extrinsic, K, WIDTH, HEIGHT)
    assert time.perf_counter() - start < 1.0


# --- dataset ---------------------------------------------------------------------------------

DIRECTIONS = list(CAMERA_MOTION_DIRECTIONS)


def _heading(extrinsic: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    forward = extrinsic[2, :3] - (extrinsic[2, :3] @ up) * up
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    return forward, right / np.linalg.norm(right)


def _bearing(extrinsic: np.ndarray, point: np.ndarray, up: np.ndarray) -> float:
    forward, right = _heading(extrinsic, up)
    offset = point - _centre(extrinsic)
    return float(np.degrees(np.arctan2(offset @ right, offset @ forward)))


def _flat_distance(offset: np.ndarray, up: np.ndarray) -> float:
    return float(np.linalg.norm(offset - (offset @ up) * up))


def _angle_gap(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    return make_dataset(tmp_path_factory.mktemp("synth"), num_scenes=3, seed=21)


def _records(jsonl: Path) -> list[dict]:
    return [json.loads(line) for line in jsonl.read_text().splitlines()]


def test_dataset_records_have_the_mindcube_fields(dataset):
    records = _records(dataset)
    assert {r["id"].split("_")[0] for r in records} == {"rotation", "around", "among"}
    assert len({r["id"] for r in records}) == len(records)
    for record in records:
        assert {"id", "question", "gt_answer", "images", "category", "type", "meta_info"} <= set(record)
        letters = re.findall(r"(?:^|\s)([A-D])\. ", record["question"])
        assert letters == list("ABCD"[: len(letters)]) and len(letters) >= 2
        assert record["gt_answer"] in letters
        for image in record["images"]:
            assert (dataset.parent / image).is_file()
        assert isinstance(record["meta_info"], list)  # as in MindCube
        scene = np.load(dataset.parent / record["pyspatial_scene"]["scene_file"])
        views = len(scene["extrinsics"])
        assert scene["intrinsics"].shape == (views, 3, 3)
        assert scene["depths"].shape == (views, HEIGHT, WIDTH)
        assert record["pyspatial_scene"]["setting"] == record["id"].split("_")[0]
        # MindCube's opening names every image, and every image is shown.
        assert record["question"].startswith("Based on these ") and "(image 1" in record["question"]
        assert len(record["images"]) == views


def test_dataset_answers_agree_with_the_saved_geometry(dataset):
    checked = set()
    for record in _records(dataset):
        meta = record["pyspatial_scene"]
        scene = np.load(dataset.parent / meta["scene_file"])
        extrinsics, up = scene["extrinsics"], scene["up"]
        centres = dict(zip(scene["object_names"].tolist(), scene["object_centres"], strict=True))
        answer = meta["options"]["ABCD".index(record["gt_answer"])]
        assert f"{record['gt_answer']}. {answer}" in record["question"]
        views = [meta["view_indices"][v] for v in meta["facts"].get("pair", [0, 1])]
        kind = record["type"]
        checked.add(kind)
        if kind == "motion":
            first, second = extrinsics[views[0]], extrinsics[views[1]]
            angle = _bearing(first, _centre(second), up)
            assert answer == DIRECTIONS[int(np.round(angle / 45.0)) % 8]
        elif kind == "turn":
            forward_1, right_1 = _heading(extrinsics[views[0]], up)
            forward_2, _ = _heading(extrinsics[views[1]], up)
            angle = float(np.degrees(np.arctan2(forward_2 @ right_1, forward_2 @ forward_1)))
            if answer.startswith("turned around"):
                assert abs(angle) > 170
            else:
                side, degrees = re.match(r"turned (left|right) by about (\d+) degrees", answer).groups()
                assert (angle > 0) == (side == "right") and abs(abs(angle) - int(degrees)) < 10
        elif kind == "relative_position":
            relation = re.search(r"what is (behind you|to your left|to your right)\?", record["question"])
            target = {"behind you": 180.0, "to your left": -90.0, "to your right": 90.0}[relation.group(1)]
            camera = extrinsics[meta["facts"]["view"]]
            assert _angle_gap(_bearing(camera, centres[answer], up), target) <= 30
            for option in meta["options"]:
                if option != answer:
                    assert _angle_gap(_bearing(camera, centres[option], up), target) >= 60
        elif kind == "approach":
            side, name = re.search(
                r"turn (left|right) 90 degrees.*farther from the (.+)\?", record["question"]
            ).groups()
            camera = extrinsics[meta["facts"]["view"]]
            _, right = _heading(camera, up)
            start = _centre(camera)
            end = start + (right if side == "right" else -right) * 1.0
            before, after = (_flat_distance(centres[name] - p, up) for p in (start, end))
            assert answer == (f"closer to the {name}" if after < before else f"farther from the {name}")
        else:
            raise AssertionError(f"unexpected question type {kind}")
    assert {"motion", "turn", "relative_position", "approach"} <= checked


def test_dataset_is_deterministic_and_depth_matches_the_images(dataset, tmp_path):
    again = make_dataset(tmp_path, num_scenes=3, seed=21)
    assert again.read_text() == dataset.read_text()
    scene = np.load(dataset.parent / "scenes" / "scene_0000.npz")
    scene_again = np.load(tmp_path / "scenes" / "scene_0000.npz")
    np.testing.assert_array_equal(scene["depths"], scene_again["depths"])
    assert np.all(scene["depths"] >= 0) and np.mean(scene["depths"] > 0) > 0.5
