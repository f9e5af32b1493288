"""Uploaded scenes on disk, content-addressed, written atomically so a crash never leaves half a scene.

The data dir is this replica's working copy. With a `DurableStore` (PYSPATIAL_STORE_DIR, a volume
every replica mounts) every scene is also written there before the upload is answered: that is the
store of record. With a `SharedScenes` mirror (Redis) it is published there too, as a hot copy. A
scene this replica has not seen is fetched from Redis, else from the durable store, so any replica
serves any scene, and Redis may forget any of them.
"""

from __future__ import annotations

import errno
import hashlib
import io
import json
import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from services.recon.durable import DurableStore
from services.recon.errors import InvalidInput, SceneNotFound, StorageFull, StorageUnavailable
from services.recon.shared_scenes import SharedScenes
from shared.wire.access import DEFAULT_TENANT

_SCENE_ID = re.compile(r"^[0-9a-f]{24}$")
POSED_RGBD, PHOTOS = "posed-rgbd", "photos"  # a scene's kind; a posed-rgbd scene's default backbone


@dataclass
class SceneInput:
    """What a client uploaded, decoded and validated."""

    image_files: list[bytes]  # the encoded files exactly as uploaded
    images: list[np.ndarray] | None = None  # decoded uint8 RGB (None: only validated, see sizes)
    depths: list[np.ndarray] | None = None
    extrinsics: np.ndarray | None = None  # (V, 3, 4)
    intrinsics: np.ndarray | None = None  # (V, 3, 3); an all-NaN matrix: not given for that view
    sizes: list[tuple[int, int]] | None = None  # (width, height) per image when `images` is None

    @property
    def num_images(self) -> int:
        return len(self.image_files)

    @property
    def image_sizes(self) -> list[tuple[int, int]]:
        if self.sizes is not None:
            return list(self.sizes)
        return [(image.shape[1], image.shape[0]) for image in self.images or []]

    @property
    def kind(self) -> str:
        """What was uploaded: "posed-rgbd" (depths, poses and intrinsics of every view) or "photos"."""
        posed = self.depths is not None and self.extrinsics is not None and has_all_intrinsics(self)
        return POSED_RGBD if posed else PHOTOS

    def content_id(self) -> str:
        """Hash of the files in order (and any depths and cameras): same upload, same scene."""
        digest = hashlib.sha256()
        for blob in self.image_files:
            digest.update(len(blob).to_bytes(8, "little") + blob)
        for name in ("depths", "extrinsics", "intrinsics"):
            value = getattr(self, name)
            if value is not None:
                digest.update(name.encode())
                for array in value:
                    digest.update(np.ascontiguousarray(array, dtype=np.float32).tobytes())
        return digest.hexdigest()[:24]


def check_scene_id(scene_id: str) -> str:
    if not _SCENE_ID.match(scene_id):
        raise SceneNotFound(
            f"unknown scene id {scene_id!r}: scene ids are 24 hex characters from POST /v1/scenes"
        )
    return scene_id


def storage_error(action: str, error: OSError) -> StorageFull | StorageUnavailable:
    """An OSError of the data dir as the HTTP error that says what failed (507 full, else 503)."""
    message = f"could not {action}: {error.strerror or error} ({error.filename or 'data dir'})"
    if error.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return StorageFull(message)
    return StorageUnavailable(message)


class SceneStore:
    def __init__(
        self, root: Path, shared: SharedScenes | None = None, durable: DurableStore | None = None
    ) -> None:
        self.root = Path(root) / "scenes"
        self.shared = shared
        self.durable = durable
        self.setup_error: str | None = None
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as error:  # the service still starts; /readyz and uploads say what failed
            self.setup_error = str(storage_error("create the data dir", error).message)

    def _path(self, scene_id: str) -> Path:
        return self.root / check_scene_id(scene_id)

    def exists(self, scene_id: str, tenant: str = DEFAULT_TENANT) -> bool:
        """Whether the tenant has this scene (fetched into the data dir when it is elsewhere)."""
        try:
            self.info(scene_id, tenant)
        except SceneNotFound:
            return False
        return True

    def _ensure_local(self, scene_id: str) -> bool:
        """True when the scene is in the data dir, fetching it from Redis or the durable store if needed."""
        if (self._path(scene_id) / "meta.json").exists():
            return True
        sources = [source.fetch for source in (self.shared,) if source is not None]
        if self.durable is not None:
            sources.append(self.durable.get_scene)
        return any(self._copy_in(scene_id, fetch) for fetch in sources)

    def _copy_in(self, scene_id: str, fetch) -> bool:
        """Let `fetch(scene_id, staging)` fill a staging dir, then rename it into place."""
        final = self._path(scene_id)
        try:
            staging = Path(tempfile.mkdtemp(prefix=".fetching-", dir=self.root))
        except OSError as error:
            raise storage_error("copy a shared scene into the data dir", error) from error
        try:
            if not fetch(scene_id, staging):
                return False
            try:
                os.rename(staging, final)
            except OSError:  # another request fetched it first
                if not (final / "meta.json").exists():
                    raise
            return True
        except OSError as error:
            raise storage_error("copy a shared scene into the data dir", error) from error
        finally:
            if staging.exists():
                shutil.rmtree(staging, ignore_errors=True)

    def check_writable(self) -> str | None:
        """None when a scene could be stored now; else what is wrong (for /readyz)."""
        if self.setup_error:
            return self.setup_error
        folders = [("data dir", self.root)]
        if self.durable is not None:
            folders.append(("durable store", self.durable.tmp))
        for label, folder in folders:
            probe = folder / f".probe-{os.getpid()}"
            try:
                probe.write_bytes(b"ok")
                probe.unlink()
                stats = os.statvfs(folder)
            except OSError as error:
                return storage_error(f"write to the {label}", error).message
            free = stats.f_bavail * stats.f_frsize
            if free < 16 * 2**20:
                return f"the {label} {folder} has only {free // 2**20} MiB free"
        return None

    def save(
        self, scene: SceneInput, scene_id: str | None = None, tenant: str = DEFAULT_TENANT
    ) -> tuple[str, bool]:
        """Store the scene (durable store, then Redis); returns (scene_id, created).

        `scene_id` defaults to the content hash (the default tenant's id); other tenants' ids come
        from `services/recon/tenants.py`, and the scene records its tenant."""
        scene_id = scene_id or scene.content_id()
        if self.setup_error:
            raise StorageUnavailable(self.setup_error)
        try:
            created = self._save_local(scene_id, scene, tenant)
        except OSError as error:
            raise storage_error("store the scene", error) from error
        if self.durable is not None:  # the store of record has it before the client hears of it
            try:
                created = self.durable.put_scene(scene_id, self._path(scene_id)) and created
            except OSError as error:
                raise storage_error("store the scene in the durable store", error) from error
        if self.shared is not None:
            self.shared.publish(scene_id, self._path(scene_id))
        return scene_id, created

    def _save_local(self, scene_id: str, scene: SceneInput, tenant: str) -> bool:
        final = self._path(scene_id)
        if (final / "meta.json").exists():
            return False
        staging = Path(tempfile.mkdtemp(prefix=".incoming-", dir=self.root))
        try:
            for index, blob in enumerate(scene.image_files):
                (staging / f"image_{index:03d}").write_bytes(blob)
            arrays: dict[str, np.ndarray] = {}
            if scene.depths is not None:
                arrays.update({f"depth_{i:03d}": d.astype(np.float32) for i, d in enumerate(scene.depths)})
            if scene.extrinsics is not None:
                arrays["extrinsics"] = scene.extrinsics
            if scene.intrinsics is not None:
                arrays["intrinsics"] = scene.intrinsics
            if arrays:
                np.savez(staging / "geometry.npz", **arrays)
            meta = {
                "num_images": scene.num_images,
                "image_sizes": scene.image_sizes,
                "has_depth": scene.depths is not None,
                "has_cameras": scene.extrinsics is not None and has_all_intrinsics(scene),
                "kind": scene.kind,  # read by every replica: the scene is reconstructed as uploaded
            }
            if tenant != DEFAULT_TENANT:  # scenes without it (and from before tenants) are the default's
                meta["tenant"] = tenant
            (staging / "meta.json").write_text(json.dumps(meta))  # written last: marks the scene complete
            try:
                os.rename(staging, final)
            except OSError:  # a concurrent upload of the same scene won the race
                if not (final / "meta.json").exists():
                    raise
                return False
        finally:
            if staging.exists():
                shutil.rmtree(staging, ignore_errors=True)
        return True

    def info(self, scene_id: str, tenant: str = DEFAULT_TENANT) -> dict:
        """The scene's metadata: num_images, image_sizes, has_depth, has_cameras, kind.

        Another tenant's scene is as unknown as one that does not exist (same 404, same message)."""
        path = self._path(scene_id)
        unknown = SceneNotFound(f"scene {scene_id} is not known here: upload its images with POST /v1/scenes")
        if not self._ensure_local(scene_id):
            raise unknown
        meta = json.loads((path / "meta.json").read_text())
        if meta.pop("tenant", DEFAULT_TENANT) != tenant:
            raise unknown
        if "kind" not in meta:  # stored before kinds were recorded: what its files say
            meta["kind"] = POSED_RGBD if meta["has_depth"] and meta["has_cameras"] else PHOTOS
        return meta

    def image_file(self, scene_id: str, index: int, tenant: str = DEFAULT_TENANT) -> bytes:
        path = self._path(scene_id)
        count = self.info(scene_id, tenant)["num_images"]
        if not 0 <= index < count:
            raise SceneNotFound(
                f"scene {scene_id} has {count} images, at indices 0..{count - 1} (0-based); "
                f"there is no index {index}"
            )
        return (path / f"image_{index:03d}").read_bytes()

    def load(self, scene_id: str, decode, tenant: str = DEFAULT_TENANT) -> SceneInput:
        """Read a stored scene; `decode(bytes, label)` turns files into RGB arrays."""
        path = self._path(scene_id)
        meta = self.info(scene_id, tenant)
        files = [(path / f"image_{i:03d}").read_bytes() for i in range(meta["num_images"])]
        images = [decode(file, f"image {i + 1}") for i, file in enumerate(files)]
        scene = SceneInput(image_files=files, images=images)
        geometry = path / "geometry.npz"
        if geometry.exists():
            with np.load(io.BytesIO(geometry.read_bytes())) as data:
                if "depth_000" in data:
                    scene.depths = [data[f"depth_{i:03d}"] for i in range(meta["num_images"])]
                scene.extrinsics = data["extrinsics"] if "extrinsics" in data else None
                scene.intrinsics = data["intrinsics"] if "intrinsics" in data else None
        return scene


def has_all_intrinsics(scene: SceneInput) -> bool:
    return scene.intrinsics is not None and bool(np.all(np.isfinite(scene.intrinsics)))


def validate_geometry(scene: SceneInput) -> None:
    """Depths and cameras, when given, must fit the images one to one."""
    views = scene.num_images
    if scene.depths is not None:
        if len(scene.depths) != views:
            raise InvalidInput(f"{len(scene.depths)} depth maps for {views} images")
        for index, depth in enumerate(scene.depths):
            if depth.ndim != 2 or min(depth.shape) < 2:
                raise InvalidInput(f"depth {index + 1} must be a 2-D array (H, W), got shape {depth.shape}")
    for name, shape in (("extrinsics", (3, 4)), ("intrinsics", (3, 3))):
        value = getattr(scene, name)
        if value is None:
            continue
        if value.shape != (views, *shape):
            raise InvalidInput(
                f"{name} must be {views} matrices of shape {shape}, got array of {value.shape}"
            )
        # Intrinsics may be left out per view (all NaN: null in the upload); anything else is finite.
        given = ~np.all(np.isnan(value), axis=(1, 2)) if name == "intrinsics" else np.ones(views, bool)
        if not np.all(np.isfinite(value[given])):
            raise InvalidInput(f"{name} contain values that are not finite")
    if scene.intrinsics is not None:
        for index, intrinsic in enumerate(scene.intrinsics):
            if np.all(np.isnan(intrinsic)):
                continue
            fx, fy = intrinsic[0, 0], intrinsic[1, 1]
            if fx <= 0 or fy <= 0 or not np.allclose(intrinsic[2], [0.0, 0.0, 1.0]):
                raise InvalidInput(
                    f"intrinsics {index + 1} must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0 "
                    "(pixels)"
                )
