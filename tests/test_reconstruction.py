"""The Reconstruction type: validation, versioned serialization and PLY export."""

from __future__ import annotations

import io
import struct

import numpy as np
import pytest

from shared.geometry.reconstruction import FORMAT_VERSION, Reconstruction, ReconstructionFormatError


def sample(num_points: int = 500, views: int = 3, with_depth: bool = True) -> Reconstruction:
    rng = np.random.default_rng(4)
    extrinsics = np.tile(np.hstack([np.eye(3), np.zeros((3, 1))]), (views, 1, 1))
    extrinsics[:, :, 3] = rng.normal(size=(views, 3))
    extrinsics[-1] = np.nan  # an unregistered view carries no pose
    intrinsics = np.tile(np.array([[100.0, 0, 31.5], [0, 100.0, 23.5], [0, 0, 1]]), (views, 1, 1))
    depths = (
        [rng.uniform(0.5, 8.0, (12, 16)).astype(np.float32) for _ in range(views)] if with_depth else None
    )
    return Reconstruction(
        points=rng.normal(scale=3.0, size=(num_points, 3)),
        colors=rng.integers(0, 256, (num_points, 3)),
        extrinsics=extrinsics,
        intrinsics=intrinsics,
        image_sizes=[(64, 48)] * views,
        registered=[True] * (views - 1) + [False],
        backbone="test",
        backbone_version="7",
        depths=depths,
        depth_confidence=[np.ones_like(d) for d in depths] if depths else None,
        warnings=["view 3 could not be registered"],
    )


def test_round_trip_keeps_everything():
    original = sample()
    restored = Reconstruction.from_bytes(original.to_bytes())
    np.testing.assert_array_equal(restored.points, original.points)
    np.testing.assert_array_equal(restored.colors, original.colors)
    np.testing.assert_array_equal(restored.extrinsics, original.extrinsics)  # NaN poses survive
    np.testing.assert_array_equal(restored.intrinsics, original.intrinsics)
    np.testing.assert_array_equal(restored.image_sizes, original.image_sizes)
    np.testing.assert_array_equal(restored.registered, original.registered)
    assert (restored.backbone, restored.backbone_version) == ("test", "7")
    assert restored.warnings == original.warnings
    for before, after in zip(original.depths, restored.depths, strict=True):
        # float16 storage: relative error below 1e-3 is enough for depth
        np.testing.assert_allclose(after, before, rtol=1e-3)
    assert restored.points.dtype == np.float32 and restored.colors.dtype == np.uint8


def test_without_depth_and_empty_cloud():
    empty = sample(num_points=0, with_depth=False)
    restored = Reconstruction.from_bytes(empty.to_bytes())
    assert restored.num_points == 0 and restored.depths is None and restored.depth_confidence is None


def test_serialized_form_is_compact():
    recon = sample(num_points=100_000, with_depth=False)
    raw = recon.points.nbytes + recon.colors.nbytes
    assert len(recon.to_bytes()) < 1.05 * raw


def test_garbage_and_other_versions_are_refused():
    with pytest.raises(ReconstructionFormatError, match="not a serialized reconstruction"):
        Reconstruction.from_bytes(b"definitely not npz")
    buffer = io.BytesIO()
    np.savez(buffer, format_version=np.array(FORMAT_VERSION + 1))
    with pytest.raises(ReconstructionFormatError, match="not supported"):
        Reconstruction.from_bytes(buffer.getvalue())
    buffer = io.BytesIO()
    np.savez(buffer, points=np.zeros((1, 3)))
    with pytest.raises(ReconstructionFormatError, match="format_version"):
        Reconstruction.from_bytes(buffer.getvalue())


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"colors": np.zeros((3, 3))}, "colours"),
        ({"intrinsics": np.zeros((2, 3, 3))}, "intrinsics"),
        ({"registered": [True]}, "registered"),
        ({"depths": [np.ones((2, 2))]}, "depths"),
    ],
)
def test_inconsistent_fields_are_rejected(change, message):
    fields = {**sample(num_points=4).__dict__, **change}
    with pytest.raises(ValueError, match=message):
        Reconstruction(**fields)


def test_ply_is_binary_with_every_point():
    recon = sample(num_points=10, with_depth=False)
    ply = recon.to_ply()
    header, body = ply.split(b"end_header\n", 1)
    assert b"element vertex 10" in header and b"binary_little_endian" in header
    assert len(body) == 10 * 15
    x, y, z, r, g, b = struct.unpack_from("<fffBBB", body, 0)
    np.testing.assert_allclose([x, y, z], recon.points[0], rtol=1e-6)
    assert [r, g, b] == recon.colors[0].tolist()


def test_camera_centres_and_bounds():
    recon = sample(num_points=3, views=2)
    recon.extrinsics[0] = np.hstack([np.eye(3), [[-1.0], [-2.0], [-3.0]]])
    np.testing.assert_allclose(recon.camera_centers()[0], [1.0, 2.0, 3.0])
    low, high = recon.bounds()  # the unregistered (NaN) camera is left out
    assert np.all(np.isfinite(low)) and np.all(np.isfinite(high))
    assert np.all(low <= [1.0, 2.0, 3.0]) and np.all(high >= [1.0, 2.0, 3.0])


def test_confidence_and_intrinsics_sources_round_trip():
    from shared.geometry.reconstruction import PairConfidence, ViewConfidence

    original = sample()
    original.intrinsics_source = ["uploaded", "self-calibrated", "prior"]
    original.view_confidence = [
        ViewConfidence(120, 0.5, 0.4, 1.0),
        ViewConfidence(80, 0.25, 0.7, 0.98),
        ViewConfidence(unregistered_reason="too few inliers (12, at least 30 needed)"),
    ]
    original.pair_confidence = [PairConfidence(0, 1, 60, 0.5, 7.5, 0.3, 1.2, "relative rotation uncertain")]
    restored = Reconstruction.from_bytes(original.to_bytes())
    assert restored.intrinsics_source == original.intrinsics_source
    assert restored.pair_confidence == original.pair_confidence
    assert restored.view_confidence[:2] == original.view_confidence[:2]
    assert restored.view_confidence[2].unregistered_reason.startswith("too few inliers")
    assert np.isnan(restored.view_confidence[2].spread)


def test_version_1_files_still_read():
    recon = sample()
    with np.load(io.BytesIO(recon.to_bytes())) as archive:
        arrays = {k: archive[k] for k in archive if k not in ("intrinsics_source", "confidence")}
    arrays["format_version"] = np.array(1, dtype=np.int32)
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    restored = Reconstruction.from_bytes(buffer.getvalue())
    assert restored.intrinsics_source == ["prior"] * 3  # backbone "test": the classical default
    assert [c.unregistered_reason is None for c in restored.view_confidence] == [True, True, False]
    assert restored.pair_confidence == []


def test_unknown_intrinsics_source_is_rejected():
    with pytest.raises(ValueError, match="intrinsics source"):
        Reconstruction(**{**sample(num_points=4).__dict__, "intrinsics_source": ["guess"] * 3})


def test_units_round_trip_and_format_2_files_keep_their_backbones_units():
    metric = Reconstruction(**{**sample().__dict__, "backbone": "pi3x", "units": "metres"})
    assert Reconstruction.from_bytes(metric.to_bytes()).units == "metres"
    assert sample().units == "relative"  # a backbone that does not say: relative
    for backbone, units in (("posed-rgbd", "metres"), ("vggt", "relative"), ("classical", "relative")):
        recon = Reconstruction(**{**sample().__dict__, "backbone": backbone, "units": None})
        with np.load(io.BytesIO(recon.to_bytes())) as archive:
            arrays = {k: archive[k] for k in archive if k != "units"}
        arrays["format_version"] = np.array(2, dtype=np.int32)  # written before units existed
        buffer = io.BytesIO()
        np.savez(buffer, **arrays)
        assert Reconstruction.from_bytes(buffer.getvalue()).units == units
    with pytest.raises(ValueError, match="unknown units"):
        Reconstruction(**{**sample(num_points=4).__dict__, "units": "feet"})


def test_point_confidence_round_trips_and_older_files_have_none():
    recon = sample()
    recon = Reconstruction(**{**recon.__dict__, "point_confidence": np.arange(recon.num_points) % 4 + 2})
    restored = Reconstruction.from_bytes(recon.to_bytes())
    assert restored.point_confidence.dtype == np.float32
    np.testing.assert_array_equal(restored.point_confidence, recon.point_confidence)
    with np.load(io.BytesIO(recon.to_bytes())) as archive:
        arrays = {k: archive[k] for k in archive if k != "point_confidence"}
    arrays["format_version"] = np.array(2, dtype=np.int32)
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    assert Reconstruction.from_bytes(buffer.getvalue()).point_confidence is None
    with pytest.raises(ValueError, match="confidences for"):
        Reconstruction(**{**recon.__dict__, "point_confidence": np.ones(3)})


def test_ply_streams_in_chunks_that_make_the_whole_file():
    recon = sample(num_points=1000)
    chunks = list(recon.ply_chunks(points_per_chunk=300))
    assert len(chunks) == 1 + 4 and b"".join(chunks) == recon.to_ply()
    assert recon.ply_size() == len(recon.to_ply())


def test_the_viewer_preview_is_sorted_by_confidence_most_confident_first():
    import base64

    from services.recon.preview import point_cloud_preview

    recon = sample(num_points=2000)
    confidence = np.random.default_rng(1).uniform(0, 10, recon.num_points)
    recon = Reconstruction(**{**recon.__dict__, "point_confidence": confidence})
    preview = point_cloud_preview("s", recon, [], [0.0, -1.0, 0.0], 500)
    sent = np.frombuffer(base64.b64decode(preview.confidence), dtype="<f4")
    positions = np.frombuffer(base64.b64decode(preview.positions), dtype="<f4").reshape(-1, 3)
    assert len(sent) == 500 and np.all(np.diff(sent) <= 0)
    # Each point keeps its own confidence: the same subsample, reordered.
    index = {tuple(p): i for i, p in enumerate(recon.points.astype(np.float32))}
    np.testing.assert_array_equal(sent, recon.point_confidence[[index[tuple(p)] for p in positions]])
    without = point_cloud_preview("s", sample(num_points=2000), [], [0.0, -1.0, 0.0], 500)
    assert without.confidence is None
