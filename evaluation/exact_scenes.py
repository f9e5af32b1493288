"""Exact cameras and depth for items that carry them, for the posed-rgbd backbone.

The synthetic generator (shared/synthetic) writes, per scene, an npz with extrinsics (V,3,4),
intrinsics (V,3,3) and depths (V,H,W), and each question's ``pyspatial_scene`` names that file
(``scene_file``, relative to the image root) and the views it shows (``view_indices``); its
``meta_info`` stays a list, as in MindCube. Uploading
the question's images together with those arrays lets posed-rgbd back-project exact geometry
instead of estimating it. Real MindCube items carry no such file and are sent as plain images.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from evaluation.dataset import BenchmarkItem
from shared.wire.client import ReconClient


@dataclass
class ExactViews:
    extrinsics: np.ndarray  # (N, 3, 4) camera-from-world
    intrinsics: np.ndarray  # (N, 3, 3)
    depths: list[np.ndarray]  # N maps of z-depth


def exact_views(item: BenchmarkItem, image_root: Path) -> ExactViews | None:
    """The item's exact cameras and depths, or None when its meta_info points to none."""
    if item.exact_scene is None:
        return None
    scene_file, view_indices = item.exact_scene["scene_file"], item.exact_scene["view_indices"]
    path = Path(image_root) / scene_file
    if not path.is_file():
        raise FileNotFoundError(f"{item.id}: pyspatial_scene.scene_file {path} does not exist")
    if len(view_indices) != len(item.images):
        raise ValueError(f"{item.id}: {len(view_indices)} view indices for {len(item.images)} images")
    with np.load(path, allow_pickle=False) as scene:
        return ExactViews(
            extrinsics=np.asarray(scene["extrinsics"][view_indices], dtype=float),
            intrinsics=np.asarray(scene["intrinsics"][view_indices], dtype=float),
            depths=[np.asarray(d, dtype=np.float32) for d in scene["depths"][view_indices]],
        )


class ExactSceneUploader:
    """Uploads each (scene file, views) combination once and remembers its scene_id."""

    def __init__(self, recon: ReconClient, image_root: Path) -> None:
        self._recon = recon
        self._image_root = Path(image_root)
        self._scene_ids: dict[tuple[str, tuple[int, ...]], str] = {}
        self._lock = threading.Lock()

    def scene_id(self, item: BenchmarkItem) -> str | None:
        """The uploaded scene for the item, or None when it has no exact data."""
        if item.exact_scene is None:
            return None
        scene_file, view_indices = item.exact_scene["scene_file"], item.exact_scene["view_indices"]
        key = (str(scene_file), tuple(int(i) for i in view_indices))
        with self._lock:
            known = self._scene_ids.get(key)
        if known is not None:
            return known
        views = exact_views(item, self._image_root)
        if views is None:
            return None
        # Two threads may upload the same scene at once; the service keys scenes by content, so the
        # second upload is a harmless no-op that returns the same id.
        created = self._recon.upload_scene(
            item.images, depths=views.depths, extrinsics=views.extrinsics, intrinsics=views.intrinsics
        )
        with self._lock:
            self._scene_ids[key] = created.scene_id
        return created.scene_id
