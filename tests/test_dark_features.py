"""Dark photos are brightened before detection and keep only their strongest keypoints (issue 36);
normally exposed photos are left as they are, with the full keypoint budget."""

from __future__ import annotations

import cv2
import numpy as np

from services.recon.backbones.classical.features import (
    DARK_MAX_FEATURES,
    MIN_GAIN,
    detect_features,
    exposure_normalized,
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
