"""Real images with exact cameras for tests, rendered from procedural scenes (shared.synthetic)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from shared.synthetic import (
    CameraRig,
    SyntheticScene,
    default_intrinsic,
    generate_scene,
    look_at,
    render_view,
)
from shared.synthetic.dataset import _scene_and_rig
from shared.synthetic.photo import photo_bytes


@dataclass
class PosedViews:
    images: list[np.ndarray]
    depths: list[np.ndarray]
    extrinsics: np.ndarray  # (V, 3, 4)
    intrinsics: np.ndarray  # (V, 3, 3)
    object_names: list[str]

    def pngs(self) -> list[bytes]:
        """PNGs as a camera writes them: with the focal length in EXIF."""
        return [photo_bytes(image, k) for image, k in zip(self.images, self.intrinsics, strict=True)]


@lru_cache(maxsize=8)
def orbit_views(
    seed: int = 0,
    num_views: int = 3,
    step_deg: float = 20.0,
    width: int = 160,
    height: int = 120,
    radius: float = 1.6,
) -> PosedViews:
    """Cameras at eye height on an arc around the room centre, looking at it."""
    scene = generate_scene(seed)
    centre = scene.room_centre.copy()
    centre[2] = 0.6
    intrinsic = default_intrinsic(width, height, 60.0)
    views = []
    for index in range(num_views):
        angle = np.radians(-90.0 + step_deg * index)
        eye = centre + radius * np.array([np.cos(angle), np.sin(angle), 0.0])
        eye[2] = 1.4
        views.append(render_view(scene, look_at(eye, centre), intrinsic, width, height))
    return PosedViews(
        images=[v.rgb for v in views],
        depths=[v.depth for v in views],
        extrinsics=np.stack([v.extrinsic for v in views]),
        intrinsics=np.stack([v.intrinsic for v in views]),
        object_names=scene.object_names,
    )


def rig_photos(
    seed: int, index: int, setting: str, intrinsic: np.ndarray, size: tuple[int, int] = (320, 240)
) -> tuple[SyntheticScene, CameraRig, list[np.ndarray]]:
    """A MindCube-style rig of the synthetic dataset ("around", "among", ...) and its photos,
    rendered with `intrinsic` (bare pixels: whoever reconstructs them is not told the focal)."""
    scene, rig, _ = _scene_and_rig(seed, index, setting)
    return scene, rig, [render_view(scene, extrinsic, intrinsic, *size).rgb for extrinsic in rig.extrinsics]


def psnr(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    diff = a.astype(np.float64) - b.astype(np.float64)
    if mask is not None:
        diff = diff[mask]
    mse = float(np.mean(diff**2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0**2 / mse)
