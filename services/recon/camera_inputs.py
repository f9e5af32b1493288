"""What the service knows about each view's camera before reconstructing: uploaded, else EXIF.

Per view, the best source available wins: intrinsics uploaded with the scene, else the focal
length in the photo's EXIF (`shared.imaging.exif`). Views with neither are left to the backbone
(self-calibration or its prior). Everything is in pixels of the upright image, the one the
backbone gets.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from services.recon.scene_store import SceneInput
from shared.imaging.exif import camera_from_exif

UPLOADED = "uploaded"
EXIF = "exif"
# Bump when what the service derives from a stored scene changes (image decoding, EXIF rules), so
# cached reconstructions made from the old derivation are not served again.
INPUTS_VERSION = "2"


@dataclass
class ViewIntrinsics:
    intrinsics: list[np.ndarray | None]  # 3x3 per view, or None when nothing is known
    sources: list[str | None]  # UPLOADED, EXIF, or None
    warnings: list[str] = field(default_factory=list)

    @property
    def known_views(self) -> list[int]:
        return [index for index, intrinsic in enumerate(self.intrinsics) if intrinsic is not None]


def view_intrinsics(scene: SceneInput) -> ViewIntrinsics:
    """Per view: uploaded intrinsics, else EXIF-derived, else None (see the module docstring)."""
    intrinsics: list[np.ndarray | None] = []
    sources: list[str | None] = []
    warnings: list[str] = []
    for index, blob in enumerate(scene.image_files):
        uploaded = None if scene.intrinsics is None else np.asarray(scene.intrinsics[index], dtype=np.float64)
        if uploaded is not None and np.all(np.isfinite(uploaded)):
            intrinsics.append(uploaded)
            sources.append(UPLOADED)
            continue
        exif, note = camera_from_exif(blob)
        if note:
            warnings.append(f"view {index + 1}: {note}; its focal length is unknown")
        if exif is not None:
            intrinsics.append(exif.intrinsic)
            sources.append(EXIF)
        else:
            intrinsics.append(None)
            sources.append(None)
    return ViewIntrinsics(intrinsics, sources, warnings)
