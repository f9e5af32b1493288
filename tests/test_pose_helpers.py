"""The pose API as generated programs see it, in the real sandbox: 4x4 extrinsics, the helpers
models reach for, and errors that state shapes and conventions and name the helper."""

from __future__ import annotations

import ast

import numpy as np
import pytest

from services.agent.sandbox import SandboxLimits, run_program
from shared.geometry import poses

LIMITS = SandboxLimits(cpu_seconds=10, wall_seconds=20, memory_mb=1024)
WORLD_UP = np.array([0.0, -1.0, 0.0])  # the cameras below are level, world y pointing down


def level_camera(center: list[float], yaw_right_deg: float) -> np.ndarray:
    at_origin = np.hstack([np.eye(3), np.zeros((3, 1))])
    rotation = poses.rotate_right(at_origin, yaw_right_deg, up=WORLD_UP)[:3, :3]
    return np.hstack([rotation, (-rotation @ np.asarray(center, dtype=float))[:, None]])


class ThreeCameras:
    """A ToolProvider with three known cameras: the second 0.5 to the right, the third turned 30 right."""

    extrinsics = [level_camera([0, 0, 0], 0), level_camera([0.5, 0, 0], 0), level_camera([0.5, 0, 0], 30)]

    def reconstruct(self) -> dict:
        return {
            "extrinsics": [pose.tolist() for pose in self.extrinsics],
            "intrinsics": [[[100.0, 0, 50], [0, 100.0, 40], [0, 0, 1]]] * 3,
            "image_sizes": [[100, 80]] * 3,
            "registered": [True] * 3,
        }

    def describe_camera_motion(self) -> list[str]:
        return []

    def synthesize_novel_view(self, extrinsic, width: int, height: int) -> bytes:
        raise RuntimeError("no renderer in this test")

    def input_image(self, index: int) -> bytes:
        raise RuntimeError("no images in this test")


def run(body: str):
    source = "def program(input_scene):\n    recon = pySpatial.reconstruct(input_scene)\n" + body
    return run_program(source, "Which way did I turn?", 3, ThreeCameras(), LIMITS)


def test_programs_get_4x4_extrinsics_and_the_helpers() -> None:
    result = run(
        "    e0, e1, e2 = recon.extrinsics\n"
        "    return {\n"
        "        'shape': list(e0.shape),\n"
        "        'inverse': bool(np.allclose(np.linalg.inv(e1) @ e1, np.eye(4))),\n"
        "        'centre': pySpatial.camera_center(e1).tolist(),\n"
        "        'centre_3x4': pySpatial.camera_center(e1[:3]).tolist(),\n"
        "        'relative': pySpatial.relative_pose(e0, e1).tolist(),\n"
        "        'heading': pySpatial.heading_angle(e1, e2),\n"
        "        'heading_back': pySpatial.heading_angle(e2, e0),\n"
        "        'distance': pySpatial.distance_to_point(e0, [0.5, 0.0, 0.0]),\n"
        "        'distance_h': pySpatial.distance_to_point(e0, [1.0, 0.0, 0.0, 2.0]),\n"
        "        'turned': list(pySpatial.rotate_left(e0).shape),\n"
        "        'turned_3x4': list(pySpatial.rotate_left(e0[:3]).shape),\n"
        "    }\n"
    )
    assert result.ok, result.error
    values = {
        key: ast.literal_eval(value)
        for key, value in (line.split(": ", 1) for line in result.clue_text.splitlines())
    }
    assert values["shape"] == [4, 4] and values["inverse"] is True
    np.testing.assert_allclose(values["centre"], [0.5, 0.0, 0.0], atol=1e-9)
    assert values["centre"] == values["centre_3x4"]
    cameras = ThreeCameras.extrinsics
    expected = poses.as_4x4(cameras[1]) @ np.linalg.inv(poses.as_4x4(cameras[0]))
    np.testing.assert_allclose(values["relative"], expected, atol=1e-9)
    # Left-positive like every horizontal angle: the third camera turned 30 degrees right.
    assert values["heading"] == pytest.approx(-30.0) and values["heading_back"] == pytest.approx(30.0)
    assert values["distance"] == pytest.approx(0.5) and values["distance_h"] == pytest.approx(0.5)
    assert values["turned"] == [4, 4] and values["turned_3x4"] == [3, 4]


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            "    return pySpatial.rotate_left(pySpatial.camera_center(recon.extrinsics[0]))\n",
            "pySpatial.rotate_left: extrinsic must be 3x4 or 4x4, got shape (3,) (that is a 3D point; pass",
        ),
        (
            "    return pySpatial.turn_around(recon.intrinsics[0])\n",
            "got shape (3, 3) (that is a rotation or an intrinsic matrix, not a pose)",
        ),
        (
            "    return pySpatial.distance_to_point(recon.extrinsics[0], [1.0, 2.0])\n",
            "point must be 3 finite numbers (x, y, z) in world coordinates",
        ),
    ],
    ids=["point-as-pose", "intrinsic-as-pose", "2d-point"],
)
def test_mistakes_are_explained_with_shapes_and_the_convention(body: str, message: str) -> None:
    result = run(body)
    assert not result.ok and message in result.error, result.error
    if "pose" in message:
        assert "4x4 camera-from-world matrix [[R, t], [0, 0, 0, 1]]" in result.error
