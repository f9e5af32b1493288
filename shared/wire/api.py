"""The paper's pySpatial API for Python callers, backed by the reconstruction service.

    from shared.wire.api import Scene, pySpatial

    scene = Scene("examples/living_room", question="Which way did the camera move?")
    recon = pySpatial.reconstruct(scene)
    print(pySpatial.describe_camera_motion(recon))
    pose = pySpatial.rotate_left(recon.extrinsics[0], 90)
    pySpatial.synthesize_novel_view(recon, pose).save("left.png")

The service URL comes from PYSPATIAL_RECON_URL (default http://127.0.0.1:8001) and its API key, when
the service has PYSPATIAL_API_KEYS, from PYSPATIAL_RECON_API_KEY; a toolkit for another URL or key is
`SpatialToolkit("http://host:8001", api_key="...")`. A refused key raises ServiceError (status 401).
Point clouds stay on the service until `Reconstruction.points()` asks for them.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image

from shared.geometry import poses
from shared.geometry.reconstruction import Reconstruction as ReconstructionData
from shared.wire.client import ImageLike, ReconClient, image_bytes
from shared.wire.schemas import ReconstructionSummary
from shared.wire.settings import AgentSettings

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".webp", ".tif", ".tiff"}


class Scene:
    """A few images of one scene, in order, and optionally the question asked about them."""

    def __init__(self, source: str | Path | Sequence[ImageLike], question: str = "") -> None:
        self.question = question
        self.images: list[bytes] = [image_bytes(item) for item in _image_list(source)]
        if not self.images:
            raise ValueError("a Scene needs at least one image")

    def __len__(self) -> int:
        return len(self.images)


def _image_list(source: str | Path | Sequence[ImageLike]) -> list[ImageLike]:
    if isinstance(source, (str, Path)):
        path = Path(source).expanduser()
        if path.is_dir():
            return sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        return [path]
    return list(source)


class Reconstruction:
    """Cameras of a reconstructed scene; the point cloud is downloaded on first use.

    `extrinsics` are (V, 3, 4) camera-from-world (OpenCV axes); views the backbone could not
    place are NaN there and False in `registered`.
    """

    def __init__(self, client: ReconClient, summary: ReconstructionSummary) -> None:
        self._client = client
        self._data: ReconstructionData | None = None
        self.scene_id = summary.scene_id
        self.backbone = summary.backbone
        self.registered = np.array([camera.registered for camera in summary.cameras], dtype=bool)
        nan_pose = np.full((3, 4), np.nan)
        self.extrinsics = np.array(
            [camera.extrinsic if camera.registered else nan_pose for camera in summary.cameras], dtype=float
        )
        nan_intrinsic = np.full((3, 3), np.nan)  # a view without a camera (e.g. VGGT's zero field of view)
        self.intrinsics = np.array(
            [nan_intrinsic if c.intrinsic is None else c.intrinsic for c in summary.cameras], dtype=float
        )
        self.intrinsics_source = [camera.intrinsics_source for camera in summary.cameras]
        self.image_sizes = [(camera.width, camera.height) for camera in summary.cameras]
        self.up = np.asarray(summary.up, dtype=float)
        # "metres" (pi3x, posed-rgbd) or "relative": what move_forward's distance is measured in.
        self.units = summary.units
        self.num_points = summary.num_points
        self.warnings = list(summary.warnings)

    @property
    def num_views(self) -> int:
        return len(self.extrinsics)

    def download(self) -> ReconstructionData:
        """The full reconstruction (points, colours, depths) from the service, fetched once."""
        if self._data is None:
            self._data = self._client.reconstruction(self.scene_id, self.backbone)
        return self._data

    def points(self) -> np.ndarray:
        """(N, 3) float32 world points."""
        return self.download().points

    def colors(self) -> np.ndarray:
        """(N, 3) uint8 RGB, one per point."""
        return self.download().colors

    def __repr__(self) -> str:
        registered = int(self.registered.sum())
        return (
            f"Reconstruction(scene_id={self.scene_id!r}, backbone={self.backbone!r}, "
            f"views={registered}/{self.num_views} registered, points={self.num_points})"
        )


class SpatialToolkit:
    """reconstruct, describe_camera_motion, synthesize_novel_view and the pose tools."""

    rotate_left = staticmethod(poses.rotate_left)
    rotate_right = staticmethod(poses.rotate_right)
    move_forward = staticmethod(poses.move_forward)
    move_backward = staticmethod(poses.move_backward)
    turn_around = staticmethod(poses.turn_around)
    camera_center = staticmethod(poses.camera_center)

    def __init__(
        self, recon_url: str | None = None, timeout: float = 600.0, api_key: str | None = None
    ) -> None:
        self._recon_url = recon_url
        self._timeout = timeout
        self._api_key = api_key
        self._client: ReconClient | None = None

    @property
    def client(self) -> ReconClient:
        # Created on first use, so PYSPATIAL_RECON_URL / PYSPATIAL_RECON_API_KEY set after import count.
        if self._client is None:
            settings = AgentSettings()
            url = self._recon_url or settings.recon_url
            key = self._api_key
            if key is None and settings.recon_api_key is not None:
                key = settings.recon_api_key.get_secret_value()
            self._client = ReconClient(url, timeout=self._timeout, api_key=key)
        return self._client

    def reconstruct(self, scene: Scene, backbone: str | None = None) -> Reconstruction:
        created = self.client.upload_scene(scene.images)
        return Reconstruction(self.client, self.client.reconstruct(created.scene_id, backbone))

    def describe_camera_motion(
        self, recon: Reconstruction, from_view: int | None = None, to_view: int | None = None
    ) -> str:
        """One sentence per consecutive pair of views ("From view 1 to view 2 the camera moved ..."), or
        why unknown; with `from_view` and `to_view` (1-based, as questions count images) the sentence
        of that one pair, consecutive or not ("From view 1 to view 3 ...")."""
        return self.client.camera_motion(
            recon.scene_id, backbone=recon.backbone, from_view=from_view, to_view=to_view
        ).text

    def synthesize_novel_view(
        self,
        recon: Reconstruction,
        extrinsic: np.ndarray,
        width: int = 512,
        height: int = 512,
        as_array: bool = False,
    ) -> Image.Image | np.ndarray:
        """The point cloud rendered from `extrinsic`, as a PIL image (or an RGB array)."""
        png = self.client.render(
            recon.scene_id, extrinsic, width=width, height=height, backbone=recon.backbone
        )
        image = Image.open(io.BytesIO(png)).convert("RGB")
        return np.asarray(image) if as_array else image

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None


pySpatial = SpatialToolkit()

__all__ = ["Reconstruction", "Scene", "SpatialToolkit", "pySpatial"]
