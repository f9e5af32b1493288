"""The `vggt` backbone end to end with the reduced model's weights on drawn images of several sizes."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from safetensors.torch import load_file, save_file

from services.recon.backbones.base import BackboneError, create_backbone
from services.recon.backbones.vggt.backbone import VGGTBackbone
from services.recon.backbones.vggt.geometry import unproject_depth_maps
from services.recon.backbones.vggt.preprocessing import ViewPlacement, preprocess_images
from shared.geometry.reconstruction import Reconstruction

DATA = Path(__file__).parent / "data" / "vggt"
TINY = {"checkpoint": str(DATA / "tiny_vggt.safetensors"), "config": str(DATA / "tiny_vggt_config.json")}
SMALL_SIZE = 126  # 9 x 9 patches keeps each forward pass in tens of milliseconds


def drawn_image(width: int, height: int, seed: int) -> np.ndarray:
    """A colour gradient with a few flat rectangles and a disc: structure, not noise."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:height, 0:width]
    image = np.stack(
        [255 * u / max(width - 1, 1), 255 * v / max(height - 1, 1), 128 + 64 * np.sin(u / 7.0 + v / 11.0)], -1
    )
    for _ in range(3):
        x0, y0 = rng.integers(0, width // 2), rng.integers(0, height // 2)
        image[y0 : y0 + height // 3, x0 : x0 + width // 3] = rng.integers(0, 256, size=3)
    disc = (u - width * 0.6) ** 2 + (v - height * 0.4) ** 2 < (min(width, height) / 5) ** 2
    image[disc] = (250, 240, 20)
    return np.clip(image, 0, 255).astype(np.uint8)


@pytest.fixture(scope="module")
def images() -> list[np.ndarray]:
    return [drawn_image(160, 120, 1), drawn_image(100, 200, 2), drawn_image(90, 90, 3)]


@pytest.fixture(scope="module")
def backbone() -> VGGTBackbone:
    return VGGTBackbone(**TINY, device="cpu", image_size=SMALL_SIZE)


@pytest.fixture(scope="module")
def reconstruction(backbone: VGGTBackbone, images: list[np.ndarray]) -> Reconstruction:
    return backbone.reconstruct(images)


def test_registry_builds_the_backbone_with_default_image_size() -> None:
    backbone = create_backbone("vggt", **TINY, device="cpu")
    assert isinstance(backbone, VGGTBackbone)
    assert backbone.image_size == 518 and backbone.name == "vggt"
    assert backbone.ready()[0]
    result = backbone.reconstruct([drawn_image(64, 48, 5), drawn_image(40, 60, 6)])
    assert result.depths[0].shape == (392, 518)  # 48 * 518 / 64 = 388.5 -> 392 rows
    assert result.depths[1].shape == (784, 518)  # 60 * 518 / 40 = 777 -> 784 rows, 518 kept


def test_shapes_and_metadata(reconstruction: Reconstruction, backbone: VGGTBackbone) -> None:
    assert reconstruction.num_views == 3
    assert reconstruction.image_sizes.tolist() == [[160, 120], [100, 200], [90, 90]]
    assert reconstruction.registered.tolist() == [True, True, True]
    assert reconstruction.backbone == "vggt" and reconstruction.backbone_version == backbone.version
    # Depth grids are the resized images: width 126, height rounded to multiples of 14.
    assert [d.shape for d in reconstruction.depths] == [(98, 126), (252, 126), (126, 126)]
    assert [c.shape for c in reconstruction.depth_confidence] == [(98, 126), (252, 126), (126, 126)]
    assert all(d.dtype == np.float32 for d in reconstruction.depths)
    assert np.isfinite(reconstruction.points).all() and reconstruction.num_points > 0
    # The tall view lost half its rows to the centre crop: they are unknown, not invented.
    tall = reconstruction.depths[1]
    assert (tall[:63] == 0).all() and (tall[189:] == 0).all() and (tall[63:189] > 0).all()
    # Warnings count views from 1: the tall view (index 1) is "view 2".
    assert any("view 2" in warning and "centre crop" in warning for warning in reconstruction.warnings)
    assert (reconstruction.depths[0] > 0).all() and (reconstruction.depth_confidence[0] >= 1).all()


def test_intrinsics_are_in_original_pixels(reconstruction: Reconstruction) -> None:
    for (width, height), intrinsic in zip(reconstruction.image_sizes, reconstruction.intrinsics, strict=True):
        # VGGT's principal point is its frame centre, which maps back to each image's centre.
        assert intrinsic[0, 2] == pytest.approx(width / 2, rel=1e-6)
        assert intrinsic[1, 2] == pytest.approx(height / 2, rel=1e-6)
        assert intrinsic[0, 0] > 0 and intrinsic[1, 1] > 0 and intrinsic[2].tolist() == [0, 0, 1]


def test_depth_maps_with_scaled_intrinsics_give_the_network_frame_points(
    backbone: VGGTBackbone, images: list[np.ndarray], reconstruction: Reconstruction
) -> None:
    """The stored depth grid, with intrinsics scaled by (w / width, h / height), lands exactly on
    the points that unprojection in the network frame gives."""
    arrays, placements = backbone.predict(images)
    network_points = unproject_depth_maps(arrays["depth"], arrays["extrinsic"], arrays["intrinsic"])
    for view, placement in enumerate(placements):
        depth = reconstruction.depths[view]
        width, height = reconstruction.image_sizes[view]
        scale = np.diag([depth.shape[1] / width, depth.shape[0] / height, 1.0])
        intrinsic = scale @ reconstruction.intrinsics[view]
        stored = unproject_depth_maps(depth[None], reconstruction.extrinsics[view][None], intrinsic[None])[0]
        expected = placement.to_resized_grid(network_points[view])
        known = depth > 0
        np.testing.assert_allclose(stored[known], expected[known], rtol=1e-5, atol=1e-6)


def test_confidence_percentile_keeps_the_expected_share(
    backbone: VGGTBackbone, images: list[np.ndarray]
) -> None:
    window_pixels = 126 * 98 + 126 * 126 + 126 * 126  # every pixel the network saw, padding excluded
    everything = backbone.reconstruct(images, confidence_percentile=0.0, colour_space="srgb")
    assert everything.num_points == window_pixels
    assert everything.warnings[0] == "vggt ignores option 'colour_space'"
    # Confidences are continuous, so ties are absent and the share is exact up to one point.
    half = backbone.reconstruct(images)  # the constructor's default: 50
    assert abs(half.num_points - window_pixels * 0.5) <= 1
    strict = VGGTBackbone(**TINY, device="cpu", image_size=SMALL_SIZE, confidence_percentile=90.0)
    assert abs(strict.reconstruct(images).num_points - window_pixels * 0.1) <= 1
    with pytest.raises(BackboneError, match="confidence_percentile"):
        backbone.reconstruct(images, confidence_percentile=120)


def test_points_are_the_most_confident_depth_pixels(backbone: VGGTBackbone, images: list[np.ndarray]) -> None:
    arrays, placements = backbone.predict(images)
    world = unproject_depth_maps(arrays["depth"], arrays["extrinsic"], arrays["intrinsic"])
    windows = [p.network_window() for p in placements]
    scores = np.concatenate([arrays["depth_conf"][i][w].ravel() for i, w in enumerate(windows)])
    points = np.concatenate([world[i][w].reshape(-1, 3) for i, w in enumerate(windows)])
    expected = points[scores >= np.percentile(scores, 50.0)].astype(np.float32)
    result = backbone.reconstruct(images)
    np.testing.assert_array_equal(result.points, expected)


def test_colours_come_from_the_original_images(backbone: VGGTBackbone) -> None:
    red = np.zeros((60, 80, 3), dtype=np.uint8)
    red[..., 0] = 200
    two_tone = np.zeros((100, 50, 3), dtype=np.uint8)
    two_tone[:, :25] = (10, 20, 30)
    two_tone[:, 25:] = (40, 50, 60)
    result = VGGTBackbone(**TINY, device="cpu", image_size=SMALL_SIZE, confidence_percentile=0).reconstruct(
        [red, two_tone]
    )
    counted = {
        tuple(c): n for c, n in zip(*np.unique(result.colors, axis=0, return_counts=True), strict=True)
    }
    assert set(counted) == {(200, 0, 0), (10, 20, 30), (40, 50, 60)}
    assert counted[(200, 0, 0)] == 126 * 98  # 80x60 -> 126 x 94.5 -> 98 rows
    assert counted[(10, 20, 30)] == counted[(40, 50, 60)] == 126 * 126 // 2  # cropped to 126 rows


def test_results_are_reproducible(backbone: VGGTBackbone, images: list[np.ndarray]) -> None:
    first = backbone.reconstruct(images)
    second = VGGTBackbone(**TINY, device="cpu", image_size=SMALL_SIZE).reconstruct(images)
    assert first.backbone_version == second.backbone_version
    for name in ("points", "colors", "extrinsics", "intrinsics"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name), err_msg=name)
    for a, b in zip(first.depths, second.depths, strict=True):
        np.testing.assert_array_equal(a, b)
    # Through the binary format the reconstruction survives (depths as float16).
    restored = Reconstruction.from_bytes(first.to_bytes())
    np.testing.assert_array_equal(restored.points, first.points)


def test_point_head_source_and_pad_mode(images: list[np.ndarray]) -> None:
    backbone = VGGTBackbone(
        **TINY, device="cpu", image_size=SMALL_SIZE, point_source="points", preprocess_mode="pad"
    )
    result = backbone.reconstruct(images)
    # Pad mode: longest side 126, nothing cropped; the depth grid is the resized image.
    # 100x200 -> 126 rows and 63 / 14 = 4.5 patches, which Python (and VGGT) round to 4: 56 columns.
    assert [d.shape for d in result.depths] == [(98, 126), (126, 56), (126, 126)]
    assert not result.warnings
    arrays, placements = backbone.predict(images)
    assert arrays["world_points"].shape == (3, 126, 126, 3)
    pixels = sum(p.content_size[0] * p.content_size[1] for p in placements)
    assert abs(result.num_points - pixels / 2) <= 1
    for (width, height), intrinsic in zip(result.image_sizes, result.intrinsics, strict=True):
        assert intrinsic[0, 2] == pytest.approx(width / 2) and intrinsic[1, 2] == pytest.approx(height / 2)


def test_version_follows_the_weights(tmp_path: Path, backbone: VGGTBackbone) -> None:
    same = tmp_path / "same.safetensors"
    shutil.copyfile(TINY["checkpoint"], same)
    assert VGGTBackbone(checkpoint=str(same), config=TINY["config"], device="cpu").version == backbone.version
    state = load_file(TINY["checkpoint"])
    state["camera_head.empty_pose_tokens"] = state["camera_head.empty_pose_tokens"] + 1.0
    changed = tmp_path / "changed.safetensors"
    save_file(state, str(changed))
    assert (
        VGGTBackbone(checkpoint=str(changed), config=TINY["config"], device="cpu").version != backbone.version
    )


def test_without_checkpoint_the_backbone_is_not_ready(images: list[np.ndarray]) -> None:
    backbone = VGGTBackbone(config=TINY["config"], device="cpu")
    ready, reason = backbone.ready()
    assert not ready and "checkpoint" in reason
    with pytest.raises(BackboneError, match="checkpoint"):
        backbone.reconstruct(images)


def test_bad_checkpoint_or_settings_fail_construction(tmp_path: Path) -> None:
    with pytest.raises(BackboneError, match="does not exist"):
        VGGTBackbone(checkpoint=str(tmp_path / "missing.pt"), config=TINY["config"])
    # The full-size default config does not fit the reduced weights: every tensor is mis-shaped.
    with pytest.raises(BackboneError, match="wrong shape"):
        VGGTBackbone(checkpoint=TINY["checkpoint"], device="cpu")
    with pytest.raises(BackboneError, match="point_source"):
        VGGTBackbone(**TINY, point_source="mesh")
    with pytest.raises(BackboneError, match="multiple of 14"):
        VGGTBackbone(**TINY, image_size=100)


def test_rejects_images_that_are_not_uint8_rgb(backbone: VGGTBackbone) -> None:
    with pytest.raises(BackboneError, match="uint8"):
        backbone.reconstruct([np.zeros((20, 20, 3), dtype=np.float32)])
    with pytest.raises(BackboneError, match="at least one"):
        backbone.reconstruct([])


def test_preprocessing_follows_vggt_sizes() -> None:
    wide, tall = np.zeros((750, 1000, 3), np.uint8), np.zeros((1200, 600, 3), np.uint8)
    batch, (wide_view, tall_view) = preprocess_images([wide, tall], 518, 14, "crop")
    assert batch.shape == (2, 3, 518, 518)
    assert wide_view == ViewPlacement((1000, 750), (518, 392), (0, 0), (518, 392), (0, 63))
    assert tall_view == ViewPlacement((600, 1200), (518, 1036), (0, 259), (518, 518), (0, 0))
    # White padding around the shorter view, image content inside.
    assert float(batch[0, :, :63].min()) == 1.0 and float(batch[0, :, 63:455].max()) == 0.0
    batch, (wide_view, tall_view) = preprocess_images([wide, tall], 518, 14, "pad")
    # 259 / 14 = 18.5 columns of patches rounds (half to even) to 18: 252 pixels.
    assert wide_view.content_size == (518, 392) and tall_view.content_size == (252, 518)
    assert tall_view.paste_origin == (133, 0)
    frame_centre = np.array([[100.0, 0, 259.0], [0, 100.0, 259.0], [0, 0, 1]])
    original = tall_view.network_to_original_intrinsics(frame_centre)
    np.testing.assert_allclose(original[:2, 2], [300.0, 600.0])
    np.testing.assert_allclose(np.diag(original)[:2], [100.0 * 600 / 252, 100.0 * 1200 / 518])
