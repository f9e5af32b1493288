"""Back-projection of posed depth maps: geometry, colour lookup, grid scaling and validation."""

from __future__ import annotations

import numpy as np
import pytest

from services.recon.backbones.base import BackboneError, create_backbone
from shared.geometry.backprojection import backproject_depth, reconstruction_from_rgbd
from shared.geometry.poses import rotate_left

WIDTH, HEIGHT = 64, 48
INTRINSIC = np.array([[50.0, 0.0, 32.0], [0.0, 50.0, 24.0], [0.0, 0.0, 1.0]])


def tilted_pose() -> np.ndarray:
    base = np.hstack([np.eye(3), np.array([[0.3], [-0.2], [1.0]])])
    return rotate_left(base, 30.0)


def gradient_image() -> np.ndarray:
    rows, columns = np.mgrid[0:HEIGHT, 0:WIDTH]
    return np.stack([columns * 4, rows * 5, (rows + columns) % 256], axis=-1).astype(np.uint8)


def test_points_reproject_to_their_pixels_with_their_depth() -> None:
    rows, columns = np.mgrid[0:HEIGHT, 0:WIDTH]
    depth = (2.0 + 0.01 * columns + 0.02 * rows).astype(np.float32)
    depth[5, 7] = 0.0
    depth[6, 7] = np.nan
    pose = tilted_pose()
    points = backproject_depth(depth, INTRINSIC, pose)
    assert points.shape == (WIDTH * HEIGHT - 2, 3)
    in_camera = points @ pose[:, :3].T + pose[:, 3]
    pixels = in_camera @ INTRINSIC.T
    pixels = pixels[:, :2] / pixels[:, 2:]
    valid = np.isfinite(depth) & (depth > 0)
    np.testing.assert_allclose(pixels[:, 0], columns[valid], atol=1e-9)
    np.testing.assert_allclose(pixels[:, 1], rows[valid], atol=1e-9)
    np.testing.assert_allclose(in_camera[:, 2], depth[valid], rtol=1e-6)


def test_plane_depth_gives_coplanar_points() -> None:
    # The plane z_cam = 3 seen head-on: all points share the camera's z axis value.
    depth = np.full((HEIGHT, WIDTH), 3.0, dtype=np.float32)
    pose = tilted_pose()
    points = backproject_depth(depth, INTRINSIC, pose, stride=4)
    assert len(points) == (HEIGHT // 4) * (WIDTH // 4)
    np.testing.assert_allclose(points @ pose[2, :3] + pose[2, 3], 3.0, atol=1e-9)


def test_small_depth_scales_intrinsics_and_picks_matching_colours() -> None:
    image = gradient_image()
    full = np.full((HEIGHT, WIDTH), 2.5, dtype=np.float32)
    half = full[::2, ::2].copy()
    pose = tilted_pose()
    recon_full = reconstruction_from_rgbd([image], [full], pose[None], INTRINSIC[None])
    recon_half = reconstruction_from_rgbd([image], [half], [pose], [INTRINSIC])
    assert recon_half.num_points == recon_full.num_points // 4
    # A half-resolution sample (r, c) sits where the full grid has (2r, 2c): same point, same colour.
    full_grid = recon_full.points.reshape(HEIGHT, WIDTH, 3)[::2, ::2].reshape(-1, 3)
    np.testing.assert_allclose(recon_half.points, full_grid, atol=1e-5)
    np.testing.assert_array_equal(recon_half.colors, image[::2, ::2].reshape(-1, 3))
    assert recon_half.image_sizes.tolist() == [[WIDTH, HEIGHT]]
    assert recon_half.backbone == "posed-rgbd" and recon_half.registered.all()
    assert recon_half.depths is not None and recon_half.depths[0].shape == half.shape


def test_reconstruction_concatenates_views_and_warns_on_empty_depth() -> None:
    image = gradient_image()
    depth = np.full((HEIGHT, WIDTH), 2.0, dtype=np.float32)
    empty = np.zeros_like(depth)
    recon = reconstruction_from_rgbd([image, image], [depth, empty], [tilted_pose()] * 2, [INTRINSIC] * 2)
    assert recon.num_points == WIDTH * HEIGHT
    assert recon.warnings == ["view 2 has no valid depth"]
    assert recon.extrinsics.shape == (2, 3, 4)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"depths": []}, "1 images but 0 depths"),
        ({"images": [np.zeros((HEIGHT, WIDTH), np.uint8)]}, "uint8 \\(H, W, 3\\)"),
        ({"depths": [np.ones((HEIGHT * 2, WIDTH), np.float32)]}, "larger than its image"),
        ({"depths": [np.ones(5, np.float32)]}, "\\(h, w\\)"),
        ({"intrinsics": [np.eye(2)]}, "3x3"),
        ({"extrinsics": [np.full((3, 4), np.inf)]}, "non-finite"),
        ({"stride": 0}, "stride"),
    ],
)
def test_reconstruction_validation(change: dict, message: str) -> None:
    arguments = {
        "images": [gradient_image()],
        "depths": [np.ones((HEIGHT, WIDTH), np.float32)],
        "extrinsics": [tilted_pose()],
        "intrinsics": [INTRINSIC],
    }
    arguments.update(change)
    with pytest.raises(ValueError, match=message):
        reconstruction_from_rgbd(**arguments)


def test_posed_rgbd_backbone() -> None:
    backbone = create_backbone("posed-rgbd")
    assert (backbone.name, backbone.version) == ("posed-rgbd", "1")
    image = gradient_image()
    depth = np.full((HEIGHT, WIDTH), 2.0, dtype=np.float32)
    recon = backbone.reconstruct(
        [image], depths=[depth], extrinsics=[tilted_pose()], intrinsics=[INTRINSIC], stride=2
    )
    assert recon.num_points == WIDTH * HEIGHT // 4
    assert (recon.backbone, recon.backbone_version) == ("posed-rgbd", "1")
    with pytest.raises(BackboneError, match="needs depths, extrinsics and intrinsics.*missing: depths"):
        backbone.reconstruct([image], extrinsics=[tilted_pose()], intrinsics=[INTRINSIC])
    with pytest.raises(BackboneError, match="1 images but 2 depths"):
        backbone.reconstruct(
            [image], depths=[depth, depth], extrinsics=[tilted_pose()], intrinsics=[INTRINSIC]
        )
    with pytest.raises(BackboneError, match="unknown option"):
        backbone.reconstruct(
            [image], depths=[depth], extrinsics=[tilted_pose()], intrinsics=[INTRINSIC], colour="red"
        )
