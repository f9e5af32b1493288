"""Contract tests over HTTP: camera inputs (uploaded and EXIF intrinsics), decoded pixels, camera motion.

Real recon (classical by default) and agent processes, real Redis, real photographs (templeRing,
calibrated) and rendered synthetic scenes with exact cameras.
"""

from __future__ import annotations

import base64
import io
import uuid

import cv2
import httpx
import numpy as np
import pytest
from PIL import Image

from shared.geometry.poses import rotate_left
from shared.imaging.codecs import encode_image
from shared.imaging.exif import FILM_DIAGONAL_MM
from shared.local.services import running_service
from shared.synthetic import default_intrinsic, generate_scene, look_at, render_view
from shared.synthetic.photo import photo_bytes
from shared.wire.client import AgentClient, ReconClient, ServiceError
from tests.support.realdata import pose_errors, temple_ring
from tests.test_motion_determinacy import QUANTITIES

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
TEMPLE = (20, 23, 26)  # three photos 23 degrees apart around the temple
# Errors relative to view 0 that the classical backbone reaches on these photos with the TRUE focal:
# PNG rotation 1.7 and 2.8 degrees, centre direction 1.0 and 1.4; as JPEG (quality 95) 3.1 / 3.5 and
# 5.0 / 2.1. With the 60-degree prior instead it is 15 / 25 and 7 / 13.
PNG_TOLERANCE_DEG = (4.0, 3.0)  # (rotation, direction)
JPEG_TOLERANCE_DEG = (6.0, 6.0)
EXIF_IFD = 0x8769
Z_UP = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("recon")),
        "PYSPATIAL_CACHE_NAMESPACE": f"test-{uuid.uuid4().hex[:8]}",
        "PYSPATIAL_BACKBONE": "classical",
        "REDIS_URL": redis_url,
    }
    with running_service(RECON_APP, env) as service:
        yield service


@pytest.fixture(scope="module")
def client(recon):
    with ReconClient(recon.url, timeout=180) as client:
        yield client


def temple_pngs() -> list[bytes]:
    return [temple_ring()[number].path.read_bytes() for number in TEMPLE]


def temple_truth() -> list[np.ndarray]:
    return [temple_ring()[number].extrinsic for number in TEMPLE]


def assert_placed_like_the_truth(summary, tolerance: tuple[float, float]) -> None:
    assert all(camera.registered for camera in summary.cameras), summary.warnings
    errors = pose_errors(temple_truth(), [np.array(camera.extrinsic) for camera in summary.cameras])
    worst = np.max(errors, axis=0)
    assert worst[0] <= tolerance[0] and worst[1] <= tolerance[1], errors


# ---- intrinsics uploaded with the scene -----------------------------------------------------------


def test_uploaded_intrinsics_are_used_per_view(recon, client):
    pngs = temple_pngs()
    truth = [temple_ring()[number].intrinsic for number in TEMPLE]
    plain = client.reconstruct(client.upload_scene(pngs).scene_id)
    given_scene = client.upload_scene(pngs, intrinsics=truth)
    given = client.reconstruct(given_scene.scene_id)

    assert [c.intrinsics_source for c in given.cameras] == ["uploaded"] * 3
    for camera, intrinsic in zip(given.cameras, truth, strict=True):
        np.testing.assert_allclose(camera.intrinsic, intrinsic, rtol=1e-2)
    assert_placed_like_the_truth(given, PNG_TOLERANCE_DEG)
    # Without them the backbone had to find the focal itself: a different result.
    assert all(c.intrinsics_source not in ("uploaded", "exif") for c in plain.cameras)
    assert abs(plain.cameras[0].intrinsic[0][0] / truth[0][0, 0] - 1.0) > 0.01
    assert given_scene.scene_id != client.upload_scene(pngs).scene_id  # intrinsics are content

    # Some views without: null in JSON (or multipart); those views are left to the backbone.
    body = {
        "images": [base64.b64encode(png).decode() for png in pngs],
        "intrinsics": [truth[0].tolist(), None, truth[2].tolist()],
    }
    created = httpx.post(recon.url + "/v1/scenes", json=body, timeout=60)
    assert created.status_code == 201 and created.json()["has_cameras"] is False
    multipart = client.upload_scene(pngs, intrinsics=[truth[0], None, truth[2]])
    assert multipart.scene_id == created.json()["scene_id"]
    # View 1's focal is left to the backbone and the views cannot fix it: rather than a guessed
    # pose (or a refusal), the pairs are solved over field-of-view hypotheses, and the reply says so.
    mixed = client.reconstruct(created.json()["scene_id"])
    assert any("central hypothesis" in warning for warning in mixed.warnings), mixed.warnings


@pytest.mark.parametrize(
    ("intrinsics", "message"),
    [
        ([[[1500, 0, 320], [0, -1500, 240], [0, 0, 1]]] * 3, "fx, fy > 0"),
        ([[[1500, 0, 320], [0, 1500, 240], [0, 0, 1]]] * 2, "3 matrices"),
        ([[[1500, 0, 320], [0, 1500, 240], [0, 1, 1]], None, None], "fx, fy > 0"),
    ],
    ids=["negative-focal", "too-few", "bad-last-row"],
)
def test_bad_uploaded_intrinsics_are_422(recon, intrinsics, message):
    body = {"images": [base64.b64encode(png).decode() for png in temple_pngs()], "intrinsics": intrinsics}
    response = httpx.post(recon.url + "/v1/scenes", json=body, timeout=60)
    assert response.status_code == 422 and message in response.json()["detail"]


# ---- EXIF orientation and focal length --------------------------------------------------------------

# How each photo is stored: (transpose of the upright pixels, the EXIF orientation that undoes it).
STORED = {20: (None, 1), 23: (Image.Transpose.ROTATE_90, 6), 26: (Image.Transpose.ROTATE_270, 8)}
FOCAL_35MM = round(1520.4 * FILM_DIAGONAL_MM / 800.0)  # 82: the true focal, as a camera would round it


def phone_jpeg(number: int) -> bytes:
    """The photo as a phone stores it: pixels turned, an orientation tag, a 35 mm focal tag."""
    transpose, orientation = STORED[number]
    image = Image.open(temple_ring()[number].path).convert("RGB")
    if transpose is not None:
        image = image.transpose(transpose)
    exif = Image.Exif()
    exif[0x0112] = orientation
    exif.get_ifd(EXIF_IFD)[0xA405] = FOCAL_35MM
    buffer = io.BytesIO()
    image.save(buffer, format="JPEG", quality=95, exif=exif)
    return buffer.getvalue()


def test_exif_rotated_jpegs_with_a_focal_tag_are_placed_correctly(client):
    scene = client.upload_scene([phone_jpeg(number) for number in TEMPLE])
    assert scene.image_sizes == [(640, 480)] * 3  # upright, as the camera took them
    summary = client.reconstruct(scene.scene_id)
    assert [c.intrinsics_source for c in summary.cameras] == ["exif"] * 3
    for camera in summary.cameras:
        assert camera.intrinsic[0][0] == pytest.approx(1520.4, rel=0.01)
        assert camera.intrinsic[0][2] == pytest.approx(319.5)
        assert camera.intrinsic[1][2] == pytest.approx(239.5)
    assert_placed_like_the_truth(summary, JPEG_TOLERANCE_DEG)


# ---- pixels decoded as the file means them ----------------------------------------------------------


def single_view_colors(client, data: bytes, width: int, height: int) -> np.ndarray:
    """Upload one image with a flat depth and its camera; the posed-rgbd cloud's colours, row by row."""
    scene = client.upload_scene(
        [data],
        depths=[np.full((height, width), 2.0, np.float32)],
        extrinsics=np.hstack([np.eye(3), np.zeros((3, 1))])[None],
        intrinsics=default_intrinsic(width, height, 60.0)[None],
    )
    assert scene.image_sizes == [(width, height)]
    return client.reconstruction(scene.scene_id, backbone="posed-rgbd").colors


def encoded(image: Image.Image, fmt: str, **options) -> bytes:
    buffer = io.BytesIO()
    image.save(buffer, format=fmt, **options)
    return buffer.getvalue()


@pytest.fixture(scope="module")
def photo() -> np.ndarray:
    return np.asarray(Image.open(temple_ring()[5].path).convert("RGB").resize((96, 72)))


def test_sixteen_bit_float_transparent_and_rotated_images_decode_right(client, photo):
    grey = np.asarray(Image.fromarray(photo).convert("L"), dtype=np.float64) / 255.0
    sixteen = encoded(Image.fromarray(np.rint(grey * 65535).astype(np.uint16)), "PNG")
    floating = encoded(Image.fromarray(grey.astype(np.float32), mode="F"), "TIFF")
    expected_grey = np.repeat(np.rint(grey * 255).astype(np.uint8)[..., None], 3, axis=2)
    for data in (sixteen, floating):
        colors = single_view_colors(client, data, 96, 72)
        np.testing.assert_allclose(colors, expected_grey.reshape(-1, 3), atol=1)

    alpha = np.full((72, 96), 255, np.uint8)
    alpha[:, :40] = 0  # a cut-out: the background is white, as VGGT composites it
    rgba = encoded(Image.fromarray(np.dstack([photo, alpha]), mode="RGBA"), "PNG")
    expected = photo.copy()
    expected[:, :40] = 255
    np.testing.assert_array_equal(single_view_colors(client, rgba, 96, 72), expected.reshape(-1, 3))

    exif = Image.Exif()
    exif[0x0112] = 6
    turned = encoded(Image.fromarray(photo).transpose(Image.Transpose.ROTATE_90), "PNG", exif=exif)
    np.testing.assert_array_equal(single_view_colors(client, turned, 96, 72), photo.reshape(-1, 3))


def test_images_without_a_known_brightness_are_refused_with_the_reason(recon):
    bright = encoded(Image.fromarray(np.full((16, 16), 40.0, np.float32), mode="F"), "TIFF")
    ok, colour_float = cv2.imencode(".tiff", np.full((16, 16, 3), 0.5, np.float32))
    assert ok
    for data, message in ((bright, "[0, 1]"), (colour_float.tobytes(), "floating-point")):
        response = httpx.post(recon.url + "/v1/scenes", files=[("images", ("x.tiff", data))], timeout=30)
        assert response.status_code == 400 and message in response.json()["detail"], response.text


# ---- camera motion ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def room():
    return generate_scene(11)


def arc_images(room, count: int = 3) -> list[np.ndarray]:
    target = room.room_centre.copy()
    target[2] = 0.6
    images = []
    for index in range(count):
        angle = np.radians(-90.0 + 15.0 * index)
        eye = target + 1.9 * np.array([np.cos(angle), np.sin(angle), 0.0])
        eye[2] = 1.45
        images.append(render_view(room, look_at(eye, target), default_intrinsic(480, 360), 480, 360).rgb)
    return images


@pytest.fixture(scope="module")
def partial_scene(client, room) -> str:
    """Four views, the second blank: classical registers views 0, 2 and 3 only."""
    images = arc_images(room)
    blank = np.full_like(images[0], 128)
    scene = client.upload_scene([encode_image(image) for image in (images[0], blank, images[1], images[2])])
    summary = client.reconstruct(scene.scene_id)
    assert [c.registered for c in summary.cameras] == [True, False, True, True], summary.warnings
    # People count views from 1, in /reconstruct's warnings as in camera motion's sentences.
    assert any(w.startswith("view 2 could not be registered (") for w in summary.warnings), summary.warnings
    assert summary.cameras[1].view == 2  # the JSON field names the view as people do
    return scene.scene_id


def test_partially_registered_scene_gets_per_pair_motion(recon, partial_scene):
    response = httpx.post(recon.url + "/v1/camera-motion", json={"scene_id": partial_scene}, timeout=120)
    assert response.status_code == 200, response.text
    body = response.json()
    pairs = [(m["from_view"], m["to_view"], m["described"]) for m in body["motions"]]
    # No focal given and none the views fix: the placed pairs were solved over focal hypotheses, and
    # every such pair has its sentence of what they share (view 1 -> 4 too).
    assert pairs == [(1, 2, False), (1, 3, True), (1, 4, True), (2, 3, False), (3, 4, True)]
    assert all(m["over_focal"] is not None for m in body["motions"] if m["described"])
    # Every quantity of the vocabulary, each with its words, its range and whether all focals agree.
    for motion in (m for m in body["motions"] if m["described"]):
        quantities = motion["over_focal"]["quantities"]
        assert set(quantities) == QUANTITIES
        for name, quantity in quantities.items():
            assert quantity["determined"] == (len(quantity["words"]) == 1), (name, quantity)
        clauses = motion["sentence"].split("; ")
        for name, verb in (("tilt", "tilted"), ("roll", "rolled")):
            [clause] = [c for c in clauses if c.startswith((f"it {verb}", f"it did not {name}"))]
            mark = "(determined)" if quantities[name]["determined"] else "(not determined)"
            assert clause.endswith(mark), (clause, quantities[name])
    unknown = body["motions"][0]
    assert unknown["reason"] == "view 2 could not be registered by the classical backbone"
    assert unknown["sentence"] == (
        "From view 1 to view 2 the camera motion is unknown: view 2 could not be registered by the "
        "classical backbone."
    )
    assert body["motions"][1]["sentence"].startswith("From view 1 to view 3 the camera turned")
    assert body["text"].count("\n") == 4 and body["scene_scale"] > 0

    body = {"scene_id": partial_scene, "pairs": [[2, 4], [4, 1]]}
    explicit = httpx.post(recon.url + "/v1/camera-motion", json=body, timeout=60)
    assert explicit.status_code == 200
    assert [m["described"] for m in explicit.json()["motions"]] == [False, True]
    out_of_range = httpx.post(
        recon.url + "/v1/camera-motion", json={"scene_id": partial_scene, "pairs": [[1, 9]]}, timeout=60
    )
    assert out_of_range.status_code == 422
    assert out_of_range.json()["detail"] == ("view 9 does not exist: the scene has views 1..4")


def test_motion_of_a_view_with_an_uncertain_position_is_not_stated(recon, client):
    """Three photos (focal in EXIF) a few millimetres apart: the middle view's points meet at
    angles too shallow to fix its position, so verification flags it uncertain and camera motion
    says so for its pairs instead of stating a step; the outer views are still described."""
    scene = generate_scene(0)
    target = np.array([*scene.room_centre[:2], 0.6])
    intrinsic = default_intrinsic(320, 240)
    pngs = []
    for offset in (0.0, 0.01, 0.02):
        eye = target + np.array([offset, -1.6, 0.8])
        pngs.append(photo_bytes(render_view(scene, look_at(eye, target), intrinsic, 320, 240).rgb, intrinsic))
    uploaded = client.upload_scene(pngs)
    summary = client.reconstruct(uploaded.scene_id)
    assert [c.registered for c in summary.cameras] == [True, True, True], summary.warnings
    flags = [c.confidence.uncertain_reason for c in summary.cameras]
    assert flags[0] is None and flags[2] is None, flags
    assert flags[1].startswith("its position is uncertain: its points are seen at shallow angles"), flags
    response = httpx.post(recon.url + "/v1/camera-motion", json={"scene_id": uploaded.scene_id}, timeout=60)
    assert response.status_code == 200, response.text
    motions = {(m["from_view"], m["to_view"]): m for m in response.json()["motions"]}
    assert sorted(motions) == [(1, 2), (1, 3), (2, 3)]
    for pair in ((1, 2), (2, 3)):
        assert not motions[pair]["described"]
        assert motions[pair]["reason"] == f"view 2's pose is not certain ({flags[1]})"
        assert "the camera motion is unknown: view 2's pose is not certain" in motions[pair]["sentence"]
    assert motions[(1, 3)]["described"], motions[(1, 3)]


MOTION_PROGRAM = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.describe_camera_motion(recon)
```"""


def test_agent_tool_describes_the_pairs_it_can(recon, partial_scene, llm):
    env = {
        "PYSPATIAL_RECON_URL": recon.url,
        "PYSPATIAL_CODE_MODEL": "coder",
        "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
        "PYSPATIAL_ANSWER_MODEL": "answerer",
        "PYSPATIAL_ANSWER_MODEL_BASE_URL": llm.base_url,
        "PYSPATIAL_SANDBOX_WALL_S": "30",
    }
    llm.reset()
    llm.script([MOTION_PROGRAM], model="coder")
    llm.script(['{"reasoning": "the clue says so", "answer": "A"}'], model="answerer")
    with running_service(AGENT_APP, env) as agent, AgentClient(agent.url, timeout=180) as client:
        result = client.solve(
            "Which way did the camera move from view 1 to view 3? A. right B. left", scene_id=partial_scene
        )
    assert result.attempts[-1].error is None and len(result.attempts) == 1
    lines = result.clue.text.splitlines()
    assert len(lines) == 5  # the pairs solved over focal hypotheses included (view 1 -> 4)
    assert lines[0].startswith("From view 1 to view 2 the camera motion is unknown: view 2 could not")
    assert lines[1].startswith("From view 1 to view 3 the camera turned")
    assert lines[4].startswith("From view 3 to view 4 the camera")


def exact_pair(room, second_from_first) -> tuple[list[bytes], list[np.ndarray], np.ndarray, np.ndarray]:
    """Two rendered views with exact cameras: a level camera in the room, and a moved copy of it."""
    eye = np.array([*room.room_centre[:2], 1.4])
    first = look_at(eye, eye + np.array([1.0, 0.3, 0.0]))
    second = second_from_first(first)
    intrinsic = default_intrinsic(160, 120)
    views = [render_view(room, pose, intrinsic, 160, 120) for pose in (first, second)]
    pngs, depths = [encode_image(v.rgb) for v in views], [v.depth for v in views]
    return pngs, depths, np.stack([first, second]), np.stack([intrinsic, intrinsic])


def moved(pose: np.ndarray, step_world: np.ndarray) -> np.ndarray:
    result = pose.copy()
    result[:, 3] = pose[:, 3] - pose[:, :3] @ step_world
    return result


@pytest.mark.parametrize(
    ("second_from_first", "sentence"),
    [
        (  # a 60 degree turn with 1 cm of drift: the points, not the two centres, set the scale
            lambda first: moved(rotate_left(first, 60.0, up=Z_UP), np.array([0.006, -0.008, 0.0])),
            "From view 1 to view 2, in view 1's image axes, "
            "the camera stayed in place and turned left by about 60 degrees.",
        ),
        (
            lambda first: moved(first, np.array([0.0, 0.0, 0.5])),
            # metres
            "From view 1 to view 2, in view 1's image axes, "
            "the camera moved 0.50 m up without turning significantly.",
        ),
    ],
    ids=["turn-with-drift", "straight-up"],
)
def test_camera_motion_on_exact_cameras(client, room, second_from_first, sentence):
    pngs, depths, extrinsics, intrinsics = exact_pair(room, second_from_first)
    scene = client.upload_scene(pngs, depths=depths, extrinsics=extrinsics, intrinsics=intrinsics)
    response = client.camera_motion(scene.scene_id, backbone="posed-rgbd")
    assert response.text == sentence


def test_camera_motion_toward_a_target_point_pixel_or_the_scene_centre(client, room):
    from shared.geometry.poses import camera_center
    from shared.wire.schemas import MotionTarget, PixelTarget

    pngs, depths, extrinsics, intrinsics = exact_pair(room, lambda first: moved(first, first[2, :3] * 0.5))
    scene = client.upload_scene(pngs, depths=depths, extrinsics=extrinsics, intrinsics=intrinsics)
    ahead = MotionTarget(pixel=PixelTarget(view=1, u=80, v=60), name="the wall ahead")  # 1-based
    [motion] = client.camera_motion(scene.scene_id, backbone="posed-rgbd", target=ahead).motions
    before, after = motion.target_distances
    assert motion.target_change == "closer" and before - after == pytest.approx(0.5, abs=0.05)
    assert "; it came closer to the wall ahead (" in motion.sentence
    assert motion.image.direction == "forward" and motion.thresholds.turn_deg == 10.0
    behind = camera_center(extrinsics[0]) - 2.0 * extrinsics[0][2, :3]
    [away] = client.camera_motion(
        scene.scene_id, backbone="posed-rgbd", target=MotionTarget(point=tuple(behind))
    ).motions
    assert away.target_change == "farther" and "moved farther from the target point" in away.sentence
    [centre] = client.camera_motion(
        scene.scene_id, backbone="posed-rgbd", target=MotionTarget(scene_centre=True)
    ).motions
    assert centre.target_change is not None and "the scene's centre" in centre.sentence
    with pytest.raises(ServiceError, match="exactly one of point, pixel or scene_centre"):
        client.camera_motion(scene.scene_id, backbone="posed-rgbd", target=MotionTarget())
