"""VGGT views with a predicted field of view of 0 (an infinite focal length) are not registered.

The tiny published-architecture weights are edited so that their camera head predicts a zero
horizontal field of view for chosen views: the feedback of the field of view into the next
refinement iteration is cut (so the prediction is linear in the head's features), the features'
contribution is measured once, and the output weights are scaled and shifted so that exactly the
views with the lowest contribution end at or below 0, which the head's ReLU turns into 0.
"""

from __future__ import annotations

import uuid
from pathlib import Path

import httpx
import numpy as np
import pytest
from safetensors.torch import load_file, save_file

from services.recon.backbones.base import BackboneError
from services.recon.backbones.vggt.backbone import VGGTBackbone
from shared.imaging.codecs import decode_image, encode_image
from shared.local.services import running_service
from shared.wire.client import ReconClient
from tests.test_vggt_backbone import TINY, drawn_image

APP = "services.recon.app:create_app"
ITERATIONS = 4  # refinement iterations of the camera head (VGGTConfig default)
FOV_W = 8  # index of the horizontal field of view in the pose encoding
FOV_H = 7


def zero_fov_checkpoint(
    folder: Path, images: list[np.ndarray], image_size: int, zero_views: int
) -> tuple[Path, list[int]]:
    """A checkpoint whose camera head gives `zero_views` of `images` a zero horizontal field of view.

    Returns the file and the indices of those views. The others get a plausible field of view.
    """
    state = load_file(TINY["checkpoint"])
    state["camera_head.embed_pose.weight"][:, FOV_H:] = 0  # no feedback: linear in the features
    weight, bias = state["camera_head.pose_branch.fc2.weight"], state["camera_head.pose_branch.fc2.bias"]
    weight[FOV_H] = 0
    bias[FOV_H] = 0.8 / ITERATIONS  # vertical field of view 0.8 rad for every view
    bias[FOV_W] = 1.0 / ITERATIONS  # keeps the measurement above the ReLU
    probe = folder / "probe.safetensors"
    save_file(state, str(probe))
    measured, _ = VGGTBackbone(
        checkpoint=str(probe), config=TINY["config"], device="cpu", image_size=image_size
    ).predict(images)
    contribution = measured["pose_enc"][:, FOV_W].astype(np.float64) - 1.0
    order = np.argsort(contribution)
    threshold = (contribution[order[zero_views - 1]] + contribution[order[zero_views]]) / 2
    scale = 1.2 / (contribution[order[-1]] - threshold)  # the widest view: 1.2 rad (69 degrees)
    lowest_kept = scale * (contribution[order[zero_views]] - threshold)
    assert lowest_kept > np.radians(2.0), "the views are too alike to separate with these weights"
    weight[FOV_W] = weight[FOV_W] * float(scale)
    bias[FOV_W] = float(-scale * threshold / ITERATIONS)
    path = folder / f"zero_fov_{zero_views}.safetensors"
    save_file(state, str(path))
    return path, sorted(int(view) for view in order[:zero_views])


def test_no_usable_camera_at_all_is_an_error(tmp_path: Path) -> None:
    images = [drawn_image(160, 120, seed) for seed in (1, 2, 3)]
    state = load_file(TINY["checkpoint"])
    state["camera_head.pose_branch.fc2.weight"][FOV_W] = 0
    state["camera_head.pose_branch.fc2.bias"][FOV_W] = -1.0  # every estimate negative: ReLU gives 0
    path = tmp_path / "all_zero.safetensors"
    save_file(state, str(path))
    backbone = VGGTBackbone(checkpoint=str(path), config=TINY["config"], device="cpu", image_size=126)
    with pytest.raises(BackboneError, match="zero field of view"):
        backbone.reconstruct(images)


def test_zero_field_of_view_over_http(tmp_path: Path) -> None:
    """Through the service: the view is unregistered, nothing non-finite is sent, motion says why."""
    pngs = [encode_image(drawn_image(160, 48, seed)) for seed in (4, 5, 6)]  # wide: few tokens, fast
    decoded = [decode_image(png, max_bytes=2**20, max_pixels=2**20) for png in pngs]
    checkpoint, zero = zero_fov_checkpoint(tmp_path, decoded, 518, zero_views=1)  # the service's size
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path),
        "PYSPATIAL_CACHE_NAMESPACE": f"test-{uuid.uuid4().hex[:8]}",
        "REDIS_URL": "",
        "PYSPATIAL_BACKBONE": "vggt",
        "PYSPATIAL_VGGT_CHECKPOINT": str(checkpoint),
        "PYSPATIAL_VGGT_CONFIG": TINY["config"],
    }
    with running_service(APP, env) as service, ReconClient(service.url, timeout=300) as client:
        known = np.array([[150.0, 0.0, 79.5], [0.0, 150.0, 23.5], [0.0, 0.0, 1.0]])
        scene = client.upload_scene(pngs, intrinsics=[known, None, None])  # vggt predicts its own
        summary = client.reconstruct(scene.scene_id)
        assert any("were not used" in w and "view(s) 1" in w for w in summary.warnings), summary.warnings
        [bad] = [camera for camera in summary.cameras if not camera.registered]
        assert bad.view == zero[0] + 1 and bad.extrinsic is None and bad.intrinsic is None
        assert [camera.intrinsics_source for camera in summary.cameras] == ["predicted"] * 3
        assert any(f"view {zero[0] + 1}" in w and "zero field of view" in w for w in summary.warnings)
        body = {"scene_id": scene.scene_id}
        response = httpx.post(service.url + "/v1/camera-motion", json=body, timeout=60)
        assert response.status_code == 200, response.text
        motions = response.json()["motions"]
        for motion in motions:
            uses_bad = zero[0] + 1 in (motion["from_view"], motion["to_view"])
            assert motion["described"] is not uses_bad
            if uses_bad:
                assert motion["reason"] == f"view {zero[0] + 1} could not be registered by the vggt backbone"
                assert "unknown" in motion["sentence"] and motion["direction"] is None
        assert any(motion["described"] for motion in motions)  # the two good views are related

        result = client.reconstruction(scene.scene_id)  # the stored reconstruction itself
    kept = [view for view in range(3) if view not in zero]
    assert result.registered.tolist() == [view not in zero for view in range(3)]
    assert np.isnan(result.extrinsics[zero]).all() and np.isnan(result.intrinsics[zero]).all()
    assert np.isfinite(result.extrinsics[kept]).all() and np.isfinite(result.intrinsics[kept]).all()
    assert result.num_points > 0 and np.isfinite(result.points).all()
    assert not result.depths[zero[0]].any() and not result.depth_confidence[zero[0]].any()
    assert result.intrinsics_source == ["predicted"] * 3
