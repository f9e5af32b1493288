"""Our Pi3 and Pi3X against the published architectures: tensor names and shapes of the full-size
checkpoints, and the reference outputs (with every intermediate array) of the six fixture cases.

Fixtures in tests/data/pi3/ (see its README.md).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import load_file, save_file

from services.recon.backbones.base import BackboneError
from services.recon.backbones.pi3.checkpoint import load_pi3
from services.recon.backbones.pi3.config import Pi3Config, Pi3ConfigError
from services.recon.backbones.pi3.config_file import read_pi3_config
from services.recon.backbones.pi3.heads import rotation_from_9d
from services.recon.backbones.pi3.model import Pi3, Pi3X
from tests.support import pi3_fixtures as fx

CONDITIONING = ("depth_encoder.", "depth_emb", "ray_embed.", "pose_inject_blk.")


def published_shapes(arch: str) -> dict[str, tuple[int, ...]]:
    shapes = {}
    for line in (fx.DATA / f"{arch}_state_dict.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, shape = line.split("\t")
            shapes[name] = tuple(int(size) for size in shape.strip("()").split(",") if size.strip())
    return shapes


def shapes_of(model: torch.nn.Module) -> dict[str, tuple[int, ...]]:
    return {name: tuple(tensor.shape) for name, tensor in model.state_dict().items()}


@pytest.fixture(scope="module")
def tiny_pi3() -> Pi3:
    return fx.tiny_model("pi3")


@pytest.fixture(scope="module")
def tiny_pi3x() -> Pi3X:
    return fx.tiny_model("pi3x")


# ---- full-size architectures ----------------------------------------------------------------


def test_full_size_pi3_has_exactly_the_published_tensor_names_and_shapes() -> None:
    published = published_shapes("pi3")
    assert len(published) == 1210
    assert sum(math.prod(shape) for shape in published.values()) == 958_696_738
    with torch.device("meta"):
        model = Pi3()
    assert shapes_of(model) == published


def test_full_size_pi3x_has_the_published_tensors_with_conditioning_optional() -> None:
    published = published_shapes("pi3x")
    assert len(published) == 1873
    assert sum(math.prod(shape) for shape in published.values()) == 1_360_032_439
    optional = {name: shape for name, shape in published.items() if name.startswith(CONDITIONING)}
    assert (len(optional), sum(math.prod(s) for s in optional.values())) == (436, 367_567_104)
    with torch.device("meta"):
        full, images_only = Pi3X(), Pi3X(multimodal=False)
    assert shapes_of(full) == published
    assert shapes_of(images_only) == {n: s for n, s in published.items() if n not in optional}


def test_full_size_config_is_the_one_the_fixtures_state() -> None:
    for arch in ("pi3", "pi3x"):
        stated = json.loads((fx.DATA / f"tiny_{arch}_config.json").read_text())["full_size_values"]
        full = Pi3Config.full_size(arch)
        assert (full.encoder.embed_dim, full.encoder.depth, full.encoder.num_heads) == (1024, 24, 16)
        assert (full.decoder_dim, full.decoder.depth, full.decoder.num_heads) == (
            stated["decoder"]["embed_dim"],
            stated["decoder"]["depth"],
            stated["decoder"]["num_heads"],
        )
        head = stated["head_decoder"]
        assert (full.head_decoder.embed_dim, full.head_decoder.depth) == (head["embed_dim"], head["depth"])
        assert full.camera_decoder_out_dim == stated["camera_head"]["dim"]
        if arch == "pi3x":
            assert full.pose_inject_after == tuple(stated["multimodal"]["pose_inject_after_decoder_blocks"])
            assert full.conv_head.dim_upsample == tuple(stated["point_head"]["dim_upsample"])
            assert full.metric_out_dim == stated["metric_decoder"]["out_dim"]


# ---- the six fixture cases ------------------------------------------------------------------


def test_tiny_pi3_reproduces_the_published_outputs(tiny_pi3: Pi3, monkeypatch: pytest.MonkeyPatch) -> None:
    reference = fx.expected("pi3")
    actual = fx.run_recording(tiny_pi3, fx.images(), monkeypatch)
    fx.assert_matches(actual, reference)


@pytest.mark.parametrize("case", list(fx.PI3X_CASES))
def test_tiny_pi3x_reproduces_the_published_outputs(
    tiny_pi3x: Pi3X, case: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    reference = fx.expected("pi3x", case)
    actual = fx.run_recording(tiny_pi3x, fx.images(), monkeypatch, **fx.conditions(case, reference))
    fx.assert_matches(actual, reference)
    # The pose-injection outputs exist exactly when some view has a pose.
    assert ("debug_pose_inject_0_out" in actual) == bool(reference["mask_add_pose"].any())


def test_masks_default_to_every_view_of_a_given_condition(tiny_pi3x: Pi3X) -> None:
    reference = fx.expected("pi3x", "_intrinsics_poses_depths")
    given = fx.conditions("_intrinsics_poses_depths", reference)
    given.pop("masks")
    with torch.inference_mode():
        outputs = tiny_pi3x(fx.images(), **given)
    np.testing.assert_allclose(outputs["points"].numpy(), reference["points"], rtol=1e-4, atol=1e-5)


def test_a_single_posed_view_is_no_pose_constraint(tiny_pi3x: Pi3X) -> None:
    only_intrinsics = fx.expected("pi3x", "_intrinsics")
    given = fx.conditions("_intrinsics_poses", only_intrinsics)
    views = fx.images().shape[1]
    one = torch.tensor([[index == 0 for index in range(views)]])
    given["masks"] = (given["masks"][0], given["masks"][1], one)
    with torch.inference_mode():
        outputs = tiny_pi3x(fx.images(), **given)
    np.testing.assert_allclose(outputs["points"].numpy(), only_intrinsics["points"], rtol=1e-4, atol=1e-5)


def test_pi3_is_permutation_equivariant(tiny_pi3: Pi3) -> None:
    """No reference view: reversing the views reverses every per-view output, nothing else."""
    with torch.inference_mode():
        forward = tiny_pi3(fx.images())
        backward = tiny_pi3(fx.images().flip(1))
    for name in ("local_points", "conf", "camera_poses", "points"):
        torch.testing.assert_close(backward[name].flip(1), forward[name], rtol=1e-4, atol=1e-4)


def test_images_must_be_batched_multiples_of_the_patch(tiny_pi3: Pi3) -> None:
    patch = fx.tiny_config("pi3").patch_size
    with pytest.raises(ValueError, match="multiple of the patch size"):
        tiny_pi3(torch.zeros(1, 2, 3, 5 * patch, 7 * patch + 2))
    with pytest.raises(ValueError, match=r"\(B, N, 3, H, W\)"):
        tiny_pi3(torch.zeros(2, 3, 5 * patch, 7 * patch))


def test_rotation_from_9d_is_a_proper_rotation() -> None:
    values = torch.randn(64, 9, generator=torch.Generator().manual_seed(0))
    rotations = rotation_from_9d(values)
    eye = torch.eye(3).expand(64, 3, 3)
    torch.testing.assert_close(rotations @ rotations.transpose(-1, -2), eye, atol=1e-5, rtol=0)
    torch.testing.assert_close(torch.det(rotations), torch.ones(64), atol=1e-5, rtol=0)


# ---- strict loading -------------------------------------------------------------------------


def test_missing_unexpected_and_misshaped_tensors_are_listed(tmp_path: Path) -> None:
    state = dict(load_file(str(fx.DATA / "tiny_pi3.safetensors")))
    del state["camera_head.fc_t.bias"]
    state["point_head.extra"] = torch.zeros(2)
    wanted = tuple(state["conf_head.proj.bias"].shape)
    state["conf_head.proj.bias"] = torch.zeros(wanted[0] + 1)
    path = tmp_path / "broken.safetensors"
    save_file(state, str(path))
    with pytest.raises(BackboneError) as caught:
        load_pi3(path, fx.tiny_config("pi3"))
    message = str(caught.value)
    assert "Pi3 checkpoint" in message and "1 missing tensors: camera_head.fc_t.bias" in message
    assert "1 unexpected tensors: point_head.extra" in message
    assert f"conf_head.proj.bias ({wanted[0] + 1},) (model expects {wanted})" in message


def test_pi3x_without_its_conditioning_tensors_loads_images_only(tmp_path: Path, tiny_pi3x: Pi3X) -> None:
    state = {k: v for k, v in load_file(str(fx.DATA / "tiny_pi3x.safetensors")).items()}
    images_only = {k: v for k, v in state.items() if not k.startswith(CONDITIONING)}
    assert len(state) - len(images_only) > 0
    path = tmp_path / "images_only.safetensors"
    save_file(images_only, str(path))
    model = load_pi3(path, fx.tiny_config("pi3x"))
    assert not model.multimodal and not hasattr(model, "depth_encoder")
    reference = fx.expected("pi3x")
    with torch.inference_mode():
        outputs = model(fx.images())
        with pytest.raises(ValueError, match="without its conditioning branch"):
            model(fx.images(), intrinsics=torch.eye(3).expand(1, 3, 3, 3))
    for name in ("points", "conf", "camera_poses", "metric"):
        np.testing.assert_allclose(outputs[name].numpy(), reference[name], rtol=1e-4, atol=1e-5, err_msg=name)


def test_pi3x_with_part_of_its_conditioning_branch_is_refused(tmp_path: Path) -> None:
    state = dict(load_file(str(fx.DATA / "tiny_pi3x.safetensors")))
    # the fixture's last pose-injection block: how many there are depends on its decoder depth
    last = max(int(name.split(".")[1]) for name in state if name.startswith("pose_inject_blk."))
    dropped = sorted(name for name in state if name.startswith(f"pose_inject_blk.{last}."))
    for name in dropped:
        del state[name]
    path = tmp_path / "partial.safetensors"
    save_file(state, str(path))
    with pytest.raises(BackboneError, match=f"{len(dropped)} missing tensors: pose_inject_blk.{last}"):
        load_pi3(path, fx.tiny_config("pi3x"))


def test_pi3_weights_do_not_load_as_pi3x() -> None:
    missing, unexpected = fx.pi3_weights_read_as_pi3x()
    listing = (
        f"{len(missing)} missing tensors: {missing[0]}.*{len(unexpected)} unexpected tensors: {unexpected[0]}"
    )
    with pytest.raises(BackboneError, match=listing):
        load_pi3(fx.DATA / "tiny_pi3.safetensors", fx.tiny_config("pi3x"))


# ---- configuration --------------------------------------------------------------------------


def test_tiny_configs_are_read_from_the_fixture_format() -> None:
    pi3, pi3x = fx.tiny_config("pi3"), fx.tiny_config("pi3x")
    stated, stated_x = fx.config_values("pi3"), fx.config_values("pi3x")
    decoder, head = stated["decoder"], stated["head_decoder"]
    assert (pi3.arch, pi3.decoder_dim, pi3.decoder.depth, pi3.decoder.num_heads) == (
        "pi3",
        decoder["embed_dim"],
        decoder["depth"],
        decoder["num_heads"],
    )
    assert (pi3.head_decoder.embed_dim, pi3.head_decoder.num_heads, pi3.camera_decoder_out_dim) == (
        head["embed_dim"],
        head["num_heads"],
        stated["camera_decoder_out_dim"],
    )
    point_head = stated_x["point_head"]
    assert pi3x.pose_inject_after == tuple(stated_x["multimodal"]["pose_inject_after_decoder_blocks"])
    assert pi3x.conv_head.dim_upsample == tuple(point_head["dim_upsample"])
    assert pi3x.metric_out_dim == stated_x["metric_decoder"]["out_dim"]
    assert pi3x.conv_head.last_conv_channels == point_head["last_conv_channels"]
    assert len({pi3.fingerprint(), pi3x.fingerprint(), Pi3Config.full_size("pi3x").fingerprint()}) == 3


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda c: c["decoder"].update(qk_norm=False), "decoder.qk_norm"),
        (lambda c: c["encoder"].update(has_mask_token=True), "encoder.has_mask_token"),
        (lambda c: c["point_head"].update(padding_mode="zeros"), "point_head.padding_mode"),
        (lambda c: c["decoder"].update(featurez=3), "unknown keys in Pi3 config: decoder.featurez"),
        (lambda c: c.pop("metric_token_dim"), "lacks metric_token_dim"),
        (lambda c: c["head_decoder"].update(in_dim=7), "head_decoder.in_dim"),
    ],
)
def test_configs_that_describe_another_model_are_refused(tmp_path: Path, change, message: str) -> None:
    values = json.loads((fx.DATA / "tiny_pi3x_config.json").read_text())
    change(values)
    path = tmp_path / "config.json"
    path.write_text(json.dumps(values))
    with pytest.raises(Pi3ConfigError, match=message):
        read_pi3_config(path)
