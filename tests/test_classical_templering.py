"""The classical backbone on real photographs with calibrated cameras (Middlebury templeRing).

Self-calibration with no focal given, given intrinsics kept, refusal of wide pairs whose two-view
geometry is wrong, and the confidence fields over HTTP. The data is in the shared realdata
folder (bench/templering_data.py says where it is looked for).
"""

from __future__ import annotations

import statistics

import httpx
import numpy as np
import pytest

from bench.templering_data import load_cameras, load_image, pair_errors, realdata_dir
from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone
from shared.imaging.codecs import encode_image
from shared.wire.client import AgentClient, ReconClient
from tests.support.processes import running_service

ROOT = realdata_dir()
# The templeRing photos are part of the project's test data (shared/realdata); a checkout
# without them cannot run these tests, which is a setup error, not a pass.
if ROOT is None:
    raise RuntimeError("templeRing not found: set PYSPATIAL_REALDATA_DIR to the realdata folder")
CAMERAS = load_cameras(ROOT)
TRUE_FOCAL = 1520.4


def _scene(numbers: list[int]) -> tuple[list[np.ndarray], np.ndarray, list[np.ndarray]]:
    images = [load_image(ROOT, CAMERAS[n - 1].name) for n in numbers]
    truth = np.array([CAMERAS[n - 1].extrinsic for n in numbers])
    return images, truth, [CAMERAS[n - 1].intrinsic for n in numbers]


@pytest.fixture(scope="module")
def backbone() -> ClassicalBackbone:
    return ClassicalBackbone()


def test_self_calibrates_the_focal_from_four_views_23_degrees_apart(backbone):
    images, truth, _ = _scene([13, 16, 19, 22])
    result = backbone.reconstruct(images)
    assert result.registered.all(), result.warnings
    errors = pair_errors(result.extrinsics, truth, result.registered)
    assert statistics.median(e[0] for e in errors) <= 2.0
    assert statistics.median(e[1] for e in errors) <= 3.0
    assert result.intrinsics_source == ["self-calibrated"] * 4
    assert abs(result.intrinsics[0][0, 0] / TRUE_FOCAL - 1) < 0.05
    for confidence in result.view_confidence:
        assert confidence.inliers >= 30 and confidence.unregistered_reason is None
        assert confidence.reprojection_error_px < 1.5 and confidence.positive_depth_fraction > 0.9
    assert len(result.pair_confidence) == 6
    assert max(pair.triangulation_angle_deg for pair in result.pair_confidence) > 10


def test_given_intrinsics_are_used_and_kept_upside_down_views_included(backbone):
    images, truth, intrinsics = _scene([33, 36, 39])  # photographed upside down
    result = backbone.reconstruct(images, intrinsics=intrinsics, intrinsics_sources=["exif"] * 3)
    assert result.registered.all(), result.warnings
    assert result.intrinsics_source == ["exif"] * 3
    np.testing.assert_allclose(result.intrinsics, np.array(intrinsics), atol=1e-6)
    errors = pair_errors(result.extrinsics, truth, result.registered)
    assert statistics.median(e[0] for e in errors) <= 1.0


@pytest.mark.parametrize("numbers", [[37, 43], [15, 23]])
def test_wide_pairs_with_wrong_two_view_geometry_are_refused(backbone, numbers):
    # 61-69 degrees apart: the matches give an essential matrix 36-41 degrees off the truth.
    images, _, _ = _scene(numbers)
    with pytest.raises(BackboneError, match="could be placed with confidence.*too few inliers"):
        backbone.reconstruct(images)


def test_two_views_without_a_focal_are_solved_over_focal_hypotheses(backbone):
    # Two views 23 degrees apart fit a range of focals (the prior would place them degrees off):
    # the pair is solved at every supported field of view, and the words they all share are
    # determined. Held sideways, the step is "left" at every hypothesis, as in the truth, while the
    # turn (3 to 44 degrees right) crosses the 10-degree threshold and stays undetermined.
    from bench.templering_determinacy import SIDEWAYS, true_words
    from shared.geometry.motion_determinacy import motion_over_focal

    images, truth, intrinsics = _scene([1, 4])
    sideways = [np.ascontiguousarray(np.rot90(image, -1)) for image in images]
    result = backbone.reconstruct(sideways)
    assert result.registered.all() and result.focal_hypotheses is not None
    motion = motion_over_focal(result.focal_hypotheses.for_pair(0, 1))
    assert motion.fov_range_deg[1] - motion.fov_range_deg[0] >= 30, motion
    expected = true_words(*[np.concatenate([SIDEWAYS @ t[:, :3], SIDEWAYS @ t[:, 3:]], 1) for t in truth])
    assert motion.direction_determined and motion.directions == [expected["direction"]] == ["left"]
    assert not motion.turn_determined and set(motion.turns) == {"right", "none"}
    assert any("central hypothesis" in warning for warning in result.warnings)
    # What /v1/camera-motion makes of it (its functions, in process): the sentence of what holds.
    from services.recon.scene_motion import pair_motion

    described = pair_motion(result, (0, 1))
    assert described.over_focal["directions"] == ["left"] and described.sentence == motion.sentence
    # The focal given: no hypotheses, nothing extra to pay.
    given = backbone.reconstruct(images, intrinsics=intrinsics, intrinsics_sources=["exif"] * 2)
    assert given.registered.all() and given.intrinsics_source == ["exif"] * 2
    assert given.focal_hypotheses is None
    [(rotation, direction)] = pair_errors(given.extrinsics, truth, given.registered)
    assert rotation <= 2.0 and direction <= 3.0


_ASKS = "Based on these two images (image 1 and 2) showing the same scene: "
_MOVE = _ASKS + "How did I move from image 1 to image 2? A. forward B. right C. left D. backward"
_TURN = _ASKS + (
    "How did I turn from image 1 to image 2? A. turned left by about 30 degrees "
    "B. turned right by about 30 degrees C. did not turn"
)


# Two services and two solves, ~30-60 s; the parts have lean tests in the default run.
@pytest.mark.slow
def test_camera_motion_render_and_agent_over_http_say_what_the_focal_range_determines(tmp_path, redis_url):
    # Two sideways photos 23 degrees apart, no EXIF: the step is "left" at every focal, the turn
    # (3 to 44 degrees right) is "no turn" at some and "right" at others.
    env = {"PYSPATIAL_DATA_DIR": str(tmp_path), "PYSPATIAL_BACKBONE": "classical", "REDIS_URL": redis_url}
    images, _, _ = _scene([1, 4])
    sideways = [np.ascontiguousarray(np.rot90(image, -1)) for image in images]
    with running_service("services.recon.app:create_app", env) as service:
        with ReconClient(service.url, timeout=120) as client:
            scene_id = client.upload_scene([encode_image(image) for image in sideways]).scene_id
            response = client.camera_motion(scene_id)
            pose = np.concatenate([np.eye(3), np.zeros((3, 1))], 1).tolist()
            body = {"scene_id": scene_id, "extrinsic": pose, "width": 64, "height": 48}
            render = httpx.post(service.url + "/v1/render", json=body, timeout=60)
        agent_env = {"PYSPATIAL_RECON_URL": service.url, "PYSPATIAL_SANDBOX_WALL_S": "60"}
        with running_service("services.agent.app:create_app", agent_env) as agent:
            with AgentClient(agent.url, timeout=180) as client:
                moved = client.solve(_MOVE, scene_id=scene_id)
                turned = client.solve(_TURN, scene_id=scene_id)
    assert render.status_code == 200 and "central focal hypothesis" in render.headers["x-pyspatial-warning"]
    [motion] = response.motions
    over = motion.over_focal
    assert over is not None and over.hypotheses >= 5 and over.direction_determined
    assert over.directions == ["left"] and not over.turn_determined
    assert len(over.translation_directions) == over.hypotheses
    assert motion.sentence == over.sentence and "moved left (determined; heading" in motion.sentence
    assert any("central hypothesis" in warning for warning in response.warnings)
    assert moved.answer == "C", moved.answer_reason
    assert turned.answer is None and "cannot be determined from these photos" in turned.answer_reason
    assert "turned between" in turned.answer_reason and "degrees right" in turned.answer_reason


def test_confidence_over_http(tmp_path, redis_url):
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path),
        "PYSPATIAL_BACKBONE": "classical",
        "PYSPATIAL_MAX_IMAGE_BYTES": "2000000",
        "PYSPATIAL_MAX_REQUEST_BYTES": "8000000",
        "REDIS_URL": redis_url,
    }
    images, _, _ = _scene([6, 9, 12])
    with running_service("services.recon.app:create_app", env) as service:
        with ReconClient(service.url, timeout=120) as client:
            scene_id = client.upload_scene([encode_image(image) for image in images]).scene_id
            summary = client.reconstruct(scene_id)
    assert [camera.intrinsics_source for camera in summary.cameras] == ["self-calibrated"] * 3
    for camera in summary.cameras:
        assert camera.registered and camera.confidence is not None
        assert camera.confidence.inliers >= 30 and camera.confidence.unregistered_reason is None
        assert 0 < camera.confidence.spread <= 1 and camera.confidence.reprojection_error_px < 1.5
    assert {(pair.first, pair.second) for pair in summary.pairs} == {(1, 2), (1, 3), (2, 3)}  # 1-based
    assert all(pair.triangulation_angle_deg > 1 for pair in summary.pairs)


def test_two_groups_tied_by_a_few_points_keep_only_the_larger():
    from services.recon.backbones.classical.verification import weakly_tied_views
    from shared.geometry.reconstruction import PairConfidence

    pairs = [
        PairConfidence(0, 1, 120, 0.3, 20.0),
        PairConfidence(1, 2, 90, 0.3, 20.0),
        PairConfidence(2, 3, 12, 0.4, 40.0),  # view 3 hangs on 12 points
        PairConfidence(0, 3, 0, float("nan"), float("nan")),
    ]
    refused = weakly_tied_views(pairs)
    assert list(refused) == [3] and "12 shared points" in refused[3]
    assert weakly_tied_views(pairs[:2]) == {}
