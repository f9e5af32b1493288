"""The right-angle prior on the two largest planes narrows the focal hypotheses of views that cannot
fix their focal (services/recon/backbones/classical/plane_prior.py), and only then."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench.templering_data import load_cameras, load_image, realdata_dir
from services.agent.answering import answer_offline
from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.focal_hypotheses import FOV_GRID_DEG, pair_hypotheses
from services.recon.backbones.classical.intrinsics import guess_intrinsics
from services.recon.backbones.classical.plane_prior import (
    ASSUMPTION,
    PlanePair,
    narrow_by_orthogonal_planes,
    narrowest_fov,
)
from services.recon.routes.camera_motion import as_wire
from services.recon.scene_motion import pair_motion
from shared.geometry.motion_determinacy import FocalHypotheses
from shared.geometry.reconstruction import Reconstruction
from shared.questions.intent import parse_question
from shared.synthetic.questions import questions_for_rig
from shared.synthetic.render import default_intrinsic
from shared.wire.schemas import CameraMotionItem
from tests.support.scenes import rig_photos
from tests.support.stack import classical_recon, upload_photos
from tests.test_reconstruction import sample

SIZE = (640, 480)
TRUE_FOV_DEG = 50.0


def _planes(*angles: float | None, level: bool = True) -> list[tuple[float, PlanePair | None]]:
    """(field of view, planes) from 10 degrees in 5-degree steps, for the given plane angles."""
    return [
        (10.0 + 5.0 * i, None if angle is None else PlanePair(angle, level)) for i, angle in enumerate(angles)
    ]


def test_the_bound_is_one_step_below_the_first_right_angle_after_a_clear_contradiction():
    assert narrowest_fov(_planes(15.0, None, 40.0, 76.0, 84.0, 89.0)) == 25.0  # 84: first within 10
    # A right angle from the narrowest hypothesis on: nothing is ruled out.
    assert narrowest_fov(_planes(85.0, 60.0, 88.0)) is None
    # Off a right angle, but never clearly (within 20 degrees of it): nothing is ruled out.
    assert narrowest_fov(_planes(72.0, 75.0, 86.0)) is None
    # Planes that never meet at a right angle: the assumption does not hold, no bound.
    assert narrowest_fov(_planes(20.0, 40.0, 60.0)) is None
    assert narrowest_fov(_planes(None, None)) is None
    # Planes at a right angle of which neither faces up (a facade and a roof): no floor, no bound.
    assert narrowest_fov(_planes(15.0, 40.0, 84.0, level=False)) is None


def _orbit_extrinsic(yaw_deg: float, pivot: np.ndarray) -> np.ndarray:
    """3x4 camera-from-world of a camera turned by yaw about the vertical (OpenCV y, down), looking
    at `pivot` from 4 units away: a camera walking around one point."""
    yaw = math.radians(yaw_deg)
    world_from_camera = np.array(
        [[math.cos(yaw), 0.0, math.sin(yaw)], [0.0, 1.0, 0.0], [-math.sin(yaw), 0.0, math.cos(yaw)]]
    )
    centre = pivot - 4.0 * world_from_camera[:, 2]
    rotation = world_from_camera.T
    return np.concatenate([rotation, (-rotation @ centre)[:, None]], axis=1)


def _two_views(points: np.ndarray, seed: int = 0) -> tuple[list[np.ndarray], np.ndarray]:
    """Pixels of the points in two views 35 degrees apart around one point (true FOV 50 degrees),
    with 0.3 px noise, keeping the points both views see; and the matches (index pairs)."""
    intrinsic = guess_intrinsics(*SIZE, TRUE_FOV_DEG)
    pivot = np.array([0.0, 0.3, 4.0])
    pixels, visible = [], np.ones(len(points), bool)
    for extrinsic in (_orbit_extrinsic(0.0, pivot), _orbit_extrinsic(35.0, pivot)):
        camera = points @ extrinsic[:, :3].T + extrinsic[:, 3]
        projected = camera[:, :2] / camera[:, 2:] * intrinsic[0, 0] + intrinsic[:2, 2]
        inside = (projected >= 0).all(axis=1) & (projected < SIZE).all(axis=1) & (camera[:, 2] > 0)
        visible &= inside
        pixels.append(projected)
    rng = np.random.default_rng(seed)
    pixels = [p[visible] + rng.normal(0.0, 0.3, (int(visible.sum()), 2)) for p in pixels]
    matches = np.stack([np.arange(len(pixels[0]))] * 2, axis=1)
    return pixels, matches


def _narrowed(points: np.ndarray) -> FocalHypotheses:
    pixels, matches = _two_views(points)
    pair = pair_hypotheses(pixels[0], pixels[1], SIZE, SIZE, matches, (0, 1))
    hypotheses = FocalHypotheses(list(FOV_GRID_DEG), TRUE_FOV_DEG, [pair])
    return narrow_by_orthogonal_planes(hypotheses, pixels, [SIZE, SIZE], {(0, 1): matches}, [None, None])


def _room(rng: np.random.Generator) -> np.ndarray:
    """Points on a floor (y = 1.2, below the cameras) and on the wall behind the pivot (z = 7)."""
    floor = np.column_stack([rng.uniform(-3, 3, 500), np.full(500, 1.2), rng.uniform(1.5, 7, 500)])
    wall = np.column_stack([rng.uniform(-3, 3, 400), rng.uniform(-2, 1.2, 400), np.full(400, 7.0)])
    return np.concatenate([floor, wall])


def test_a_floor_and_a_wall_rule_out_the_narrow_fields_of_view_and_keep_the_true_one():
    narrowed = _narrowed(_room(np.random.default_rng(1)))
    (pair,) = narrowed.pairs
    assert narrowed.narrowed_by == ASSUMPTION
    assert 10.0 < min(pair.fov_deg) <= TRUE_FOV_DEG <= max(pair.fov_deg)
    assert min(pair.fov_deg) <= narrowed.central_fov_deg <= max(pair.fov_deg)
    assert len(pair.rotations) == len(pair.translations) == len(pair.inliers) == len(pair.fov_deg)


def test_points_without_two_large_planes_leave_every_hypothesis():
    rng = np.random.default_rng(2)
    cloud = np.column_stack([rng.uniform(-2, 2, 900), rng.uniform(-1.5, 1.5, 900), rng.uniform(2.5, 7, 900)])
    pixels, matches = _two_views(cloud)
    pair = pair_hypotheses(pixels[0], pixels[1], SIZE, SIZE, matches, (0, 1))
    narrowed = _narrowed(cloud)
    assert narrowed.narrowed_by is None
    assert narrowed.pairs[0].fov_deg == pair.fov_deg


def test_the_narrowing_is_stored_with_the_reconstruction():
    recon = sample(num_points=20, with_depth=False)
    recon.focal_hypotheses = _narrowed(_room(np.random.default_rng(1)))
    assert Reconstruction.from_bytes(recon.to_bytes()).focal_hypotheses == recon.focal_hypotheses


@pytest.mark.parametrize("index", [1, 4])  # the synthetic generator's "around" scenes of seed 0
def test_two_photos_walking_around_a_chair_get_a_range_that_holds_the_true_field_of_view(index):
    scene, rig, images = rig_photos(0, index, "around", default_intrinsic(320, 240))  # 60 degrees, untold
    result = ClassicalBackbone(densify=False).reconstruct(images)
    hypotheses = result.focal_hypotheses
    assert hypotheses is not None and hypotheses.narrowed_by == ASSUMPTION
    for pair in hypotheses.pairs:
        assert 10.0 < min(pair.fov_deg) <= 60.0 <= max(pair.fov_deg)
    assert any("right angle" in warning and "ruled out" in warning for warning in result.warnings)
    # Camera motion says what was assumed, and the agent still reads its sentence and answers right.
    questions = [
        q for q in questions_for_rig(scene, rig, np.random.default_rng([0, index])) if q.family == "motion"
    ]
    assert questions
    for question in questions:
        motion = pair_motion(result, tuple(question.facts["pair"]))
        assert motion.over_focal["fov_assumption"] == ASSUMPTION
        assert "ruled out by assuming that" in motion.sentence
        CameraMotionItem.model_validate(as_wire(motion.to_dict()))  # the wire type takes it
        answer = answer_offline(parse_question(question.text, len(images)), motion.sentence, [])
        assert answer.answer == question.answer_letter, answer.reason


def _templering_sideways(numbers: tuple[int, ...]) -> list[np.ndarray]:
    """templeRing photos turned sideways, no EXIF (as tests/test_classical_templering.py): pairs
    that cannot fix their focal, and whose planes rule out none of its hypotheses."""
    root = realdata_dir()
    assert root is not None, "templeRing not found: set PYSPATIAL_REALDATA_DIR to the realdata folder"
    names = [load_cameras(root)[n - 1].name for n in numbers]
    return [np.ascontiguousarray(np.rot90(load_image(root, name), -1)) for name in names]


def test_camera_motion_over_http_says_when_the_right_angle_narrowed_the_field_of_view(tmp_path, redis_url):
    _, _, around = rig_photos(0, 1, "around", default_intrinsic(320, 240))  # 60 degrees, untold
    with classical_recon(tmp_path, redis_url) as client:
        narrowed = client.camera_motion(upload_photos(client, around))
        plain = client.camera_motion(upload_photos(client, _templering_sideways((1, 4))))
    [motion] = narrowed.motions
    over = motion.over_focal
    assert over is not None and over.fov_assumption == ASSUMPTION and "right angle" in over.fov_assumption
    low, high = over.fov_range_deg
    assert 10.0 < low <= 60.0 <= high  # the narrow ones ruled out, the true one kept
    assert motion.sentence == over.sentence
    assert f"{low:.0f} to {high:.0f} degrees, narrower ones ruled out by assuming that {ASSUMPTION}" in (
        motion.sentence
    )
    assert any("ruled out by assuming that" in warning for warning in narrowed.warnings)
    # Solved over the focal too, but nothing about the scene narrowed it: no assumption named.
    [unnarrowed] = plain.motions
    assert unnarrowed.over_focal is not None and unnarrowed.over_focal.fov_assumption is None
    assert "ruled out" not in unnarrowed.sentence
