"""Our VGGT against the published architecture: tensor names of VGGT-1B and reference outputs.

Fixtures in tests/data/vggt/ (see its README.md): the full checkpoint's tensor names and shapes,
and a reduced model's random weights, input and the published implementation's outputs.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import load_file, save_file

from services.recon.backbones.base import BackboneError
from services.recon.backbones.transformer.layers import RotaryEmbedding2D
from services.recon.backbones.vggt.checkpoint import load_vggt, read_state_dict
from services.recon.backbones.vggt.config import VGGTConfig, VGGTConfigError
from services.recon.backbones.vggt.geometry import (
    pose_encoding_to_cameras,
    quaternion_to_rotation,
    unproject_depth_maps,
)
from services.recon.backbones.vggt.model import VGGT

DATA = Path(__file__).parent / "data" / "vggt"
TINY_CONFIG = DATA / "tiny_vggt_config.json"
TINY_WEIGHTS = DATA / "tiny_vggt.safetensors"


def published_tensor_shapes() -> dict[str, tuple[int, ...]]:
    shapes = {}
    for line in (DATA / "vggt1b_state_dict.txt").read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        name, shape = line.split("\t")
        shapes[name] = tuple(int(size) for size in shape.strip("()").split(",") if size.strip())
    return shapes


@pytest.fixture(scope="module")
def tiny_config() -> VGGTConfig:
    return VGGTConfig.from_json(TINY_CONFIG)


@pytest.fixture(scope="module")
def tiny_model(tiny_config: VGGTConfig) -> VGGT:
    return load_vggt(TINY_WEIGHTS, tiny_config)


def run(model: VGGT, images: torch.Tensor) -> dict[str, np.ndarray]:
    with torch.inference_mode():
        outputs = model(images)
        extrinsic, intrinsic = pose_encoding_to_cameras(outputs["pose_enc"], tuple(images.shape[-2:]))
    arrays = {name: value.numpy() for name, value in outputs.items()}
    arrays["extrinsic"], arrays["intrinsic"] = extrinsic.numpy(), intrinsic.numpy()
    arrays["points_from_depth"] = unproject_depth_maps(
        arrays["depth"][0], arrays["extrinsic"][0], arrays["intrinsic"][0]
    )
    return arrays


# ---- architecture and checkpoint compatibility ---------------------------------------------


def test_full_size_model_has_exactly_the_published_tensor_names_and_shapes() -> None:
    published = published_tensor_shapes()
    assert len(published) == 1797
    assert sum(math.prod(shape) for shape in published.values()) == 1_256_537_516
    expected = {name: shape for name, shape in published.items() if not name.startswith("track_head.")}
    with torch.device("meta"):
        model = VGGT(VGGTConfig())
    ours = {name: tuple(tensor.shape) for name, tensor in model.state_dict().items()}
    assert set(ours) == set(expected)
    assert ours == expected


def test_tiny_model_reproduces_the_published_outputs(tiny_model: VGGT) -> None:
    images = torch.from_numpy(np.load(DATA / "tiny_vggt_input.npy"))
    expected = np.load(DATA / "tiny_vggt_expected.npz")
    actual = run(tiny_model, images)
    assert sorted(expected.files) == sorted(
        ["pose_enc", "depth", "depth_conf", "world_points", "world_points_conf", "extrinsic", "intrinsic"]
        + ["points_from_depth"]
    )
    for name in expected.files:
        assert actual[name].shape == expected[name].shape, name
        # Relative 1e-4. The absolute floor covers values near zero that are differences of O(1)
        # float32 terms (points_from_depth): there the rounding of those terms (~1e-7 each, a few of
        # them) is the error, and it depends on the CPU's BLAS kernels.
        np.testing.assert_allclose(actual[name], expected[name], rtol=1e-4, atol=1e-6, err_msg=name)


def test_batched_input_with_a_leading_batch_dimension_gives_the_same_outputs(tiny_model: VGGT) -> None:
    images = torch.from_numpy(np.load(DATA / "tiny_vggt_input.npy"))
    with torch.inference_mode():
        flat = tiny_model(images)
        batched = tiny_model(images[None])
    for name in flat:
        torch.testing.assert_close(flat[name], batched[name], rtol=0, atol=0)


def test_first_frame_uses_its_own_camera_and_register_tokens(tiny_model: VGGT) -> None:
    """Reordering views changes the reference frame: pose encodings must not just permute."""
    images = torch.from_numpy(np.load(DATA / "tiny_vggt_input.npy"))
    with torch.inference_mode():
        forward = tiny_model(images)["pose_enc"][0]
        backward = tiny_model(images.flip(0))["pose_enc"][0].flip(0)
    assert not torch.allclose(forward, backward, atol=1e-3)


def test_model_rejects_images_that_are_not_a_multiple_of_the_patch_size(tiny_model: VGGT) -> None:
    with pytest.raises(ValueError, match="multiple of the patch size"):
        tiny_model(torch.zeros(2, 3, 70, 100))


# ---- checkpoint loading errors -------------------------------------------------------------


def test_missing_checkpoint_file_is_a_clear_error(tmp_path: Path, tiny_config: VGGTConfig) -> None:
    with pytest.raises(BackboneError, match="does not exist"):
        load_vggt(tmp_path / "nope.safetensors", tiny_config)


def test_unknown_checkpoint_format_is_rejected(tmp_path: Path, tiny_config: VGGTConfig) -> None:
    path = tmp_path / "weights.bin"
    path.write_bytes(b"not a checkpoint")
    with pytest.raises(BackboneError, match=r"\.pt, \.pth or \.safetensors"):
        load_vggt(path, tiny_config)


def test_corrupt_checkpoint_is_a_clear_error(tmp_path: Path, tiny_config: VGGTConfig) -> None:
    path = tmp_path / "weights.safetensors"
    path.write_bytes(b"\x00" * 64)
    with pytest.raises(BackboneError, match="cannot read VGGT checkpoint"):
        load_vggt(path, tiny_config)


def test_truncated_checkpoint_lists_the_missing_tensors(tmp_path: Path, tiny_config: VGGTConfig) -> None:
    state = load_file(str(TINY_WEIGHTS))
    del state["camera_head.pose_branch.fc2.bias"]
    del state["aggregator.camera_token"]
    path = tmp_path / "truncated.safetensors"
    save_file(state, str(path))
    with pytest.raises(BackboneError) as caught:
        load_vggt(path, tiny_config)
    message = str(caught.value)
    assert "2 missing tensors" in message
    assert "aggregator.camera_token" in message and "camera_head.pose_branch.fc2.bias" in message


def test_renamed_and_misshaped_tensors_are_listed(tmp_path: Path, tiny_config: VGGTConfig) -> None:
    state = {name: tensor.clone() for name, tensor in load_file(str(TINY_WEIGHTS)).items()}
    state["depth_head.norm.weight_renamed"] = state.pop("depth_head.norm.weight")
    state["point_head.projects.0.bias"] = torch.zeros(9)
    path = tmp_path / "renamed.pt"
    torch.save(state, path)
    with pytest.raises(BackboneError) as caught:
        load_vggt(path, tiny_config)
    message = str(caught.value)
    assert "1 missing tensors: depth_head.norm.weight" in message
    assert "1 unexpected tensors: depth_head.norm.weight_renamed" in message
    assert "point_head.projects.0.bias (9,) (model expects (8,))" in message


def test_track_head_tensors_are_ignored_and_pt_files_load(tmp_path: Path, tiny_model: VGGT) -> None:
    state = dict(read_state_dict(TINY_WEIGHTS))
    state["track_head.tracker.fmap_norm.weight"] = torch.ones(128)
    path = tmp_path / "with_track_head.pt"
    torch.save(state, path)
    reloaded = load_vggt(path, tiny_model.config)
    images = torch.from_numpy(np.load(DATA / "tiny_vggt_input.npy"))
    with torch.inference_mode():
        torch.testing.assert_close(reloaded(images)["depth"], tiny_model(images)["depth"], rtol=0, atol=0)


def test_only_track_head_tensors_are_ignored(tmp_path: Path, tiny_config: VGGTConfig) -> None:
    state = dict(read_state_dict(TINY_WEIGHTS))
    state["tracker_extra.weight"] = torch.ones(3)
    path = tmp_path / "extra.safetensors"
    save_file(state, str(path))
    with pytest.raises(BackboneError, match="1 unexpected tensors: tracker_extra.weight"):
        load_vggt(path, tiny_config)


# ---- configuration -------------------------------------------------------------------------


def test_tiny_config_is_read_from_json(tiny_config: VGGTConfig) -> None:
    assert (tiny_config.embed_dim, tiny_config.depth, tiny_config.num_heads) == (32, 24, 2)
    assert tiny_config.patch_embed.depth == 2 and tiny_config.camera_head.trunk_depth == 1
    assert tiny_config.dpt_head.out_channels == (8, 16, 32, 32)
    assert tiny_config.fingerprint() != VGGTConfig().fingerprint()


def test_config_with_unknown_keys_is_rejected(tmp_path: Path) -> None:
    path = tmp_path / "config.json"
    path.write_text('{"embed_dim": 32, "dpt_head": {"featurez": 3}}')
    with pytest.raises(VGGTConfigError, match="featurez"):
        VGGTConfig.from_json(path)


# ---- geometry ------------------------------------------------------------------------------


def test_quaternion_to_rotation_is_scalar_last_and_scale_free() -> None:
    half = math.sqrt(0.5)
    quarter_turn_about_z = torch.tensor([0.0, 0.0, half, half], dtype=torch.float64)
    expected = torch.tensor([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], dtype=torch.float64)
    torch.testing.assert_close(quaternion_to_rotation(quarter_turn_about_z), expected)
    torch.testing.assert_close(quaternion_to_rotation(3.0 * quarter_turn_about_z), expected)
    random = quaternion_to_rotation(torch.randn(10, 4, generator=torch.Generator().manual_seed(1)))
    identity = torch.eye(3).expand(10, 3, 3)
    torch.testing.assert_close(random @ random.transpose(-1, -2), identity, atol=1e-5, rtol=0)
    assert torch.allclose(torch.linalg.det(random), torch.ones(10), atol=1e-5)


def test_pose_encoding_decodes_focal_lengths_from_fields_of_view() -> None:
    fov_h, fov_w = 2 * math.atan(35 / 70.0), 2 * math.atan(49 / 80.0)
    encoding = torch.tensor([[0.1, -0.2, 0.3, 0.0, 0.0, 0.0, 1.0, fov_h, fov_w]], dtype=torch.float64)
    extrinsic, intrinsic = pose_encoding_to_cameras(encoding, (70, 98))
    torch.testing.assert_close(extrinsic[0, :, :3], torch.eye(3, dtype=torch.float64))
    torch.testing.assert_close(extrinsic[0, :, 3], torch.tensor([0.1, -0.2, 0.3], dtype=torch.float64))
    expected = torch.tensor([[80.0, 0, 49.0], [0, 70.0, 35.0], [0, 0, 1]], dtype=torch.float64)
    torch.testing.assert_close(intrinsic[0], expected)


def test_unprojected_depth_projects_back_to_its_pixels() -> None:
    rng = np.random.default_rng(3)
    rotation = quaternion_to_rotation(torch.tensor(rng.normal(size=4))).numpy()
    extrinsic = np.concatenate([rotation, rng.normal(size=(3, 1))], axis=1)
    intrinsic = np.array([[50.0, 0, 16.0], [0, 55.0, 12.0], [0, 0, 1]])
    depth = rng.uniform(0.5, 4.0, size=(1, 24, 32))
    world = unproject_depth_maps(depth, extrinsic[None], intrinsic[None])[0]
    camera = world @ rotation.T + extrinsic[:, 3]
    np.testing.assert_allclose(camera[..., 2], depth[0], rtol=1e-10)
    pixels = camera @ intrinsic.T
    v, u = np.mgrid[0:24, 0:32]
    np.testing.assert_allclose(pixels[..., 0] / pixels[..., 2], u, atol=1e-9)
    np.testing.assert_allclose(pixels[..., 1] / pixels[..., 2], v, atol=1e-9)


def test_rotary_embedding_depends_only_on_relative_positions() -> None:
    rope = RotaryEmbedding2D(100.0)
    generator = torch.Generator().manual_seed(0)
    query, key = torch.randn(1, 1, 1, 16, generator=generator), torch.randn(1, 1, 1, 16, generator=generator)

    def score(query_position: tuple[int, int], key_position: tuple[int, int]) -> float:
        rotated_q = rope(query, torch.tensor([[query_position]]))
        rotated_k = rope(key, torch.tensor([[key_position]]))
        return float((rotated_q * rotated_k).sum())

    assert score((3, 5), (1, 2)) == pytest.approx(score((10, 7), (8, 4)), rel=1e-5)
    assert score((3, 5), (1, 2)) != pytest.approx(score((3, 5), (2, 1)), rel=1e-3)
    rotated = rope(query, torch.tensor([[(4, 9)]]))
    assert float(rotated.norm()) == pytest.approx(float(query.norm()), rel=1e-6)
