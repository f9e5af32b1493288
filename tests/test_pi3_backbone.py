"""The pi3 / pi3x backbones: preprocessing as published, our camera convention, conditioning plumbing,
units, lazy loading, limits. Tiny fixture weights (tests/data/pi3/)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from services.recon.backbones import create_backbone
from services.recon.backbones.base import BackboneError
from services.recon.backbones.pi3.backbone import DEFAULT_CONFIDENCE
from services.recon.backbones.pi3.cameras import extrinsics_from_poses, fit_focal
from services.recon.backbones.pi3.preprocessing import ViewScale, preprocess, resize_depth, target_size
from tests.support import pi3_fixtures as fx

TINY = {
    "pi3": {
        "checkpoint": str(fx.DATA / "tiny_pi3.safetensors"),
        "config": str(fx.DATA / "tiny_pi3_config.json"),
    },
    "pi3x": {
        "checkpoint": str(fx.DATA / "tiny_pi3x.safetensors"),
        "config": str(fx.DATA / "tiny_pi3x_config.json"),
    },
}
FIXTURE_PIXELS = fx.input_pixels()  # the fixture images' own size: preprocessing keeps them as they are


def fixture_images() -> list[np.ndarray]:
    images = np.load(fx.DATA / "tiny_pi3_input.npy")
    return [np.round(image.transpose(1, 2, 0) * 255).astype(np.uint8) for image in images]


@pytest.fixture(scope="module")
def pi3x():
    return create_backbone("pi3x", **TINY["pi3x"], pixel_limit=FIXTURE_PIXELS)


def test_target_size_follows_the_published_rule() -> None:
    assert target_size(640, 480) == (574, 434)  # 588 x 434 would pass 255,000 pixels
    _views, height, width = fx.input_shape()
    assert target_size(width, height, FIXTURE_PIXELS) == (width, height)
    assert target_size(1920, 1080) == (672, 378)
    for width, height in ((640, 480), (1920, 1080), (300, 1200), (3000, 40)):
        w, h = target_size(width, height)
        assert w % 14 == 0 and h % 14 == 0 and w * h <= 255_000


def test_views_of_another_shape_are_stretched_to_the_first_views_size() -> None:
    first = np.zeros((120, 160, 3), np.uint8)
    other = np.full((200, 100, 3), 255, np.uint8)
    batch, resized, scales = preprocess([first, other])
    assert batch.shape == (1, 2, 3, 434, 574) and resized.shape == (2, 434, 574, 3)
    assert float(batch.max()) == 1.0 and float(batch.min()) == 0.0
    assert scales[1].factors == pytest.approx((574 / 100, 434 / 200))


def test_intrinsics_go_to_the_network_and_back() -> None:
    scale = ViewScale((160, 120), (574, 434))
    ours = np.array([[150.0, 0.0, 79.5], [0.0, 140.0, 59.5], [0.0, 0.0, 1.0]])
    network = scale.intrinsics_to_network(ours)
    # The published convention puts pixel centres at +0.5: the image centre is (W/2, H/2) there.
    assert network[0, 2] == pytest.approx(574 / 2) and network[1, 2] == pytest.approx(434 / 2)
    back = scale.network_to_original(
        (network[0, 0], network[1, 1]), (network[0, 2] - 0.5, network[1, 2] - 0.5)
    )
    np.testing.assert_allclose(back, ours)


def test_focal_lengths_are_fitted_to_camera_frame_points() -> None:
    height, width, fx_, fy_ = 42, 56, 61.0, 47.0
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    depth = 2.0 + np.sin(u / 7.0)
    points = np.stack(((u - (width - 1) / 2) / fx_ * depth, (v - (height - 1) / 2) / fy_ * depth, depth), -1)
    (fitted_x, fitted_y), centre = fit_focal(points, np.ones((height, width)))
    assert (fitted_x, fitted_y) == pytest.approx((fx_, fy_)) and centre == ((width - 1) / 2, (height - 1) / 2)
    assert np.isnan(fit_focal(points * np.array([-1.0, 1.0, 1.0]), np.ones((height, width)))[0][0])


def test_poses_become_camera_from_world() -> None:
    angle = 0.3
    pose = np.eye(4)
    pose[:3, :3] = [[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]]
    pose[:3, 3] = [1.0, -2.0, 0.5]
    [extrinsic] = extrinsics_from_poses(pose[None])
    np.testing.assert_allclose(-extrinsic[:, :3].T @ extrinsic[:, 3], pose[:3, 3])  # the camera centre
    np.testing.assert_allclose(extrinsic[:, :3] @ pose[:3, :3], np.eye(3), atol=1e-12)


def test_pi3x_reconstruction_is_metric_and_in_our_convention(pi3x) -> None:
    assert pi3x._model is None  # nothing loads before the first reconstruction
    images = fixture_images()
    recon = pi3x.reconstruct(images)
    model = pi3x._model
    assert model is not None and pi3x.reconstruct(images) is not None and pi3x._model is model  # once
    assert recon.units == "metres" and recon.backbone == "pi3x"
    batch = torch.from_numpy(np.stack(images)).permute(0, 3, 1, 2).float().div(255)[None]
    with torch.inference_mode():
        direct = model(batch)
    # Random weights: a view whose points fit no positive focal length is no camera, and says so.
    placed = recon.registered
    confidence = torch.sigmoid(direct["conf"][0, ..., 0]).numpy()
    fits = [
        np.isfinite(fit_focal(points, np.where(weight >= DEFAULT_CONFIDENCE, weight, 0.0))[0]).all()
        for points, weight in zip(direct["local_points"][0].numpy(), confidence, strict=True)
    ]
    assert placed.tolist() == fits and (recon.num_points > 0) == placed.any()
    for index in np.flatnonzero(~placed):
        assert np.isnan(recon.extrinsics[index]).all() and not recon.depths[index].any()
        assert f"view {index + 1} could not be registered: pi3x gave no usable camera" in recon.warnings
    expected = extrinsics_from_poses(direct["camera_poses"][0].numpy())
    np.testing.assert_allclose(recon.extrinsics[placed], expected[placed], atol=1e-5)
    depth = direct["local_points"][0, ..., 2].numpy()
    np.testing.assert_allclose(np.stack(recon.depths)[placed], depth[placed], rtol=1e-5)
    for confidence in recon.depth_confidence:
        assert confidence.min() >= 0.0 and confidence.max() <= 1.0
    assert recon.intrinsics_source == ["predicted"] * len(images)


def test_pi3x_is_conditioned_on_given_intrinsics_and_posed_depth(pi3x) -> None:
    images = fixture_images()
    published_k = np.load(fx.DATA / "tiny_pi3x_intrinsics.npy").astype(np.float64)
    ours = published_k.copy()
    ours[:, :2, 2] -= 0.5  # our pixel convention: centres at integers
    poses = np.load(fx.DATA / "tiny_pi3x_poses.npy").astype(np.float64)
    depths = np.load(fx.DATA / "tiny_pi3x_depths.npy")
    extrinsics = extrinsics_from_poses(poses)
    sources = [("uploaded", "exif")[index % 2] for index in range(len(images))]
    recon = pi3x.reconstruct(
        images,
        intrinsics=list(ours),
        intrinsics_sources=sources,
        depths=list(depths),
        extrinsics=extrinsics,
    )
    batch = torch.from_numpy(np.stack(images)).permute(0, 3, 1, 2).float().div(255)[None]
    with torch.inference_mode():
        direct = pi3x._model(
            batch,
            intrinsics=torch.from_numpy(published_k).float()[None],
            poses=torch.from_numpy(poses).float()[None],
            depths=torch.from_numpy(depths)[None],
        )
    np.testing.assert_allclose(
        recon.extrinsics, extrinsics_from_poses(direct["camera_poses"][0].numpy()), rtol=1e-4, atol=1e-4
    )
    assert recon.intrinsics_source == sources
    np.testing.assert_allclose(recon.intrinsics, ours)


def test_depth_maps_are_resized_by_nearest_neighbour() -> None:
    depth = np.array([[1.0, 0.0], [np.nan, -2.0]], dtype=np.float32)
    resized = resize_depth(depth, (4, 4))
    np.testing.assert_array_equal(resized[:2, :2], 1.0)
    assert (resized[2:] == 0).all() and (resized[:2, 2:] == 0).all()


def test_pi3_is_relative_and_ignores_cameras() -> None:
    backbone = create_backbone("pi3", **TINY["pi3"], pixel_limit=FIXTURE_PIXELS)
    images = fixture_images()
    recon = backbone.reconstruct(images, intrinsics=[np.eye(3)] * len(images))
    assert recon.units == "relative" and "pi3 ignores option 'intrinsics'" in recon.warnings


def test_too_many_views_are_refused_before_the_model_runs() -> None:
    images = fixture_images()
    backbone = create_backbone("pi3x", **TINY["pi3x"], max_views=len(images) - 1)
    with pytest.raises(BackboneError, match=f"at most {len(images) - 1} views"):
        backbone.reconstruct(images)
    assert backbone._model is None


def test_without_weights_the_backbone_says_what_to_run() -> None:
    backbone = create_backbone("pi3x", config=TINY["pi3x"]["config"])
    ready, reason = backbone.ready()
    assert not ready and "run `pyspatial weights pull pi3x`" in reason


def test_weights_that_do_not_fit_are_refused_when_the_backbone_is_built(tmp_path: Path) -> None:
    missing, _unexpected = fx.pi3_weights_read_as_pi3x()
    with pytest.raises(BackboneError, match=f"does not fit pi3x: {len(missing)} missing tensors"):
        create_backbone("pi3x", checkpoint=TINY["pi3"]["checkpoint"], config=TINY["pi3x"]["config"])
    with pytest.raises(BackboneError, match="describes pi3, not pi3x"):
        create_backbone("pi3x", config=TINY["pi3"]["config"])
