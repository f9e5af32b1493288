"""The synthetic weak-texture ring (shared/synthetic/weak_texture_ring.py) and the Middlebury-format
reader the benches use on it (bench/ring_data.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bench.ring_data import load_ring, ring_subset
from shared.synthetic.weak_texture_ring import HEIGHT, WIDTH, make_ring


def test_a_ring_is_written_in_the_middlebury_format_and_read_back(tmp_path: Path) -> None:
    cameras = make_ring(tmp_path / "ring", seed=5, views=4)
    ring = load_ring(tmp_path / "ring")
    assert [view.name for view in ring.views] == [camera.name for camera in cameras]
    for view, camera in zip(ring.views, cameras, strict=True):
        np.testing.assert_allclose(view.intrinsic, camera.intrinsic, rtol=1e-10)
        np.testing.assert_allclose(view.extrinsic, camera.extrinsic, atol=1e-10)
        centre = view.intrinsic @ view.extrinsic @ np.array([0.0, 0.0, 0.0, 1.0])
        u, v = centre[:2] / centre[2]
        assert 0.3 * WIDTH < u < 0.7 * WIDTH and 0.3 * HEIGHT < v < 0.7 * HEIGHT  # the object in view
    image = ring.image(1)
    assert image.shape == (HEIGHT, WIDTH, 3) and np.percentile(image, 99.5) < 100  # a dark photo
    assert ring.azimuths == pytest.approx(
        {index + 1: c.azimuth_deg for index, c in enumerate(cameras)}, abs=1e-5
    )
    assert ring_subset(ring, 1, 2, 2) == [1, 3]


def test_the_same_seed_gives_the_same_ring_and_another_seed_another(tmp_path: Path) -> None:
    first = make_ring(tmp_path / "a", seed=5, views=1)
    again = make_ring(tmp_path / "b", seed=5, views=1)
    other = make_ring(tmp_path / "c", seed=6, views=1)
    assert (tmp_path / "a" / first[0].name).read_bytes() == (tmp_path / "b" / again[0].name).read_bytes()
    assert not np.allclose(first[0].extrinsic, other[0].extrinsic)
