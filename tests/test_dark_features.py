"""Dark photos are brightened before detection and keep only their strongest keypoints (issue 36);
normally exposed photos are left as they are, with the full keypoint budget. A dark view's
simulated tilts are detected only when no pair ties it well (backbone.WELL_TIED_MATCHES)."""

from __future__ import annotations

import cv2
import numpy as np

from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.backbone import WELL_TIED_MATCHES
from services.recon.backbones.classical.features import (
    DARK_MAX_FEATURES,
    MIN_GAIN,
    detect_features,
    exposure_normalized,
    is_dark,
    match_features,
    with_tilts,
)


def _textured(seed: int = 2) -> np.ndarray:
    """A 640x480 full-range image with texture at several scales (thousands of SIFT keypoints)."""
    rng = np.random.default_rng(seed)
    image = np.zeros((480, 640), np.float32)
    for sigma in (1.5, 3.0, 6.0):
        image += cv2.GaussianBlur(rng.normal(0, 1, (480, 640)).astype(np.float32), (0, 0), sigma) * sigma
    image = (image - image.min()) / (image.max() - image.min()) * 255
    return image.astype(np.uint8)


def test_a_well_exposed_photo_is_left_as_it_is_with_the_full_budget() -> None:
    image = _textured()
    assert exposure_normalized(image) is image
    assert len(detect_features(image, 4000)) > 1.5 * DARK_MAX_FEATURES  # the cap would have bitten


def test_a_dark_photo_is_brightened_and_keeps_its_strongest_keypoints_only() -> None:
    image = _textured()
    dark = (image.astype(np.float32) / (2 * MIN_GAIN)).astype(np.uint8)  # brightest pixels ~20%
    brightened = exposure_normalized(dark)
    assert brightened is not dark and brightened.max() > 2 * dark.max()
    found = detect_features(dark, 4000)
    # the image's own pass keeps DARK_MAX_FEATURES, each simulated tilt half as many
    assert DARK_MAX_FEATURES // 2 < len(found) <= 1.5 * DARK_MAX_FEATURES
    assert len(found.descriptors) <= 1.5 * DARK_MAX_FEATURES + 1


def _shifted_pair(seed: int, shift: int) -> tuple[np.ndarray, np.ndarray]:
    """Two dark RGB views of one textured image, the second moved `shift` pixels to the left."""
    wide = _textured(seed)
    wide = np.concatenate([wide, _textured(seed + 1)[:, :shift]], axis=1)
    dark = (wide.astype(np.float32) / (2 * MIN_GAIN)).astype(np.uint8)
    first, second = dark[:, :640], dark[:, shift : shift + 640]
    return tuple(cv2.cvtColor(view, cv2.COLOR_GRAY2RGB) for view in (first, second))


def test_tilts_added_later_are_the_tilts_detected_at_once() -> None:
    dark = (_textured().astype(np.float32) / (2 * MIN_GAIN)).astype(np.uint8)
    assert is_dark(dark) and not is_dark(_textured())
    at_once = detect_features(dark, 4000)
    later = with_tilts(detect_features(dark, 4000, tilts=()), dark, 4000)
    assert len(later.descriptors) > len(detect_features(dark, 4000, tilts=()).descriptors)
    for field in ("keypoints", "descriptors", "owners"):
        assert np.array_equal(getattr(at_once, field), getattr(later, field))


def test_a_dark_view_gets_its_tilts_only_when_no_pair_ties_it_well() -> None:
    backbone = ClassicalBackbone()
    first, second = _shifted_pair(seed=5, shift=40)  # mostly the same texture: many matches
    views = [backbone._prepare(i, image, backbone.fov_deg, None) for i, image in enumerate((first, second))]
    plain = [len(view.features.descriptors) for view in views]
    tied = {(0, 1): match_features(views[0].features, views[1].features)}
    assert len(tied[(0, 1)]) >= WELL_TIED_MATCHES
    kept, _ = backbone._tilts_where_needed(list(views), [0, 1], tied)
    assert [len(view.features.descriptors) for view in kept] == plain
    # The same views with too few matches between them (the pair's strongest few only): both get
    # their tilts, and the pair is matched again with them.
    loose = {(0, 1): tied[(0, 1)][: WELL_TIED_MATCHES // 2]}
    rescued, matches = backbone._tilts_where_needed(list(views), [0, 1], loose)
    assert all(len(view.features.descriptors) > count for view, count in zip(rescued, plain, strict=True))
    assert len(matches[(0, 1)]) >= len(tied[(0, 1)])
    assert all(view.gray is None for view in (*kept, *rescued))
