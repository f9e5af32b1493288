"""What the reconstruction service does, independent of HTTP: scenes in, reconstructions out."""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass

import anyio
import numpy as np

from services.recon.backbone_menu import AUTO, availability, resolve_auto
from services.recon.backbones import Backbone, BackboneError, create_backbone
from services.recon.backbones.base import BackboneLoadError
from services.recon.cache import ReconstructionCache
from services.recon.camera_inputs import INPUTS_VERSION, view_intrinsics
from services.recon.checkpoints import CATALOGUE, WEIGHTS_ABSENT, locate
from services.recon.durable import DurableStore
from services.recon.errors import BackboneNotInstalled, BackboneUnavailable, InvalidInput
from services.recon.jobs import ReconstructionJobs
from services.recon.offload import run_cpu, run_in_daemon_thread
from services.recon.scene_motion import describe_scene_motion
from services.recon.scene_store import (
    POSED_RGBD,
    SceneInput,
    SceneStore,
    check_scene_id,
    storage_error,
    validate_geometry,
)
from services.recon.shared_scenes import SharedScenes
from services.recon.store_gc import StoreCollector
from services.recon.tenants import SceneIds, load_or_create_secret
from shared.geometry.camera_motion import CameraMotion, UnknownMotion
from shared.geometry.poses import validate_extrinsic
from shared.geometry.reconstruction import Reconstruction, ReconstructionFormatError
from shared.geometry.rendering import synthesize_novel_view
from shared.imaging.codecs import decode_image, encode_image
from shared.wire.access import DEFAULT_TENANT
from shared.wire.schemas import MotionTarget
from shared.wire.settings import ReconSettings

log = logging.getLogger("pyspatial.recon")


@dataclass
class StorageStatus:
    ok: bool
    detail: str
    warnings: list[str]


@dataclass
class ReconstructOutcome:
    reconstruction: Reconstruction
    cached: bool
    joined_in_flight: bool
    timings_ms: dict[str, float]


class ReconService:
    def __init__(self, settings: ReconSettings) -> None:
        self.settings = settings
        shared = (
            SharedScenes(settings.redis_url, settings.cache_namespace, settings.scene_ttl_s)
            if settings.redis_url and settings.shared_scenes
            else None
        )
        durable, durable_error = _durable_store(settings)
        self.store = SceneStore(settings.data_dir, shared, durable)
        self.store.setup_error = self.store.setup_error or durable_error
        self.cache = ReconstructionCache(
            settings.redis_url,
            settings.cache_ttl_s,
            settings.memory_cache_mb * 2**20,
            settings.cache_namespace,
            durable,
        )
        self._backbones: dict[str, Backbone] = {}
        self._backbone_errors: dict[str, str] = {}
        self._backbone_lock = threading.Lock()
        self._scene_ids: SceneIds | None = None
        self._scene_ids_lock = threading.Lock()
        self._decoded: OrderedDict[str, Reconstruction] = OrderedDict()  # a few hot scenes, deserialized
        self.jobs = ReconstructionJobs(
            self.cache,
            workers=settings.reconstruct_workers,
            max_queued=settings.max_queued_reconstructions,
            lease_s=settings.reconstruct_lease_s,
            wait_s=settings.reconstruct_wait_s,
        )

    # ---- backbones ---------------------------------------------------------------------------

    def resolve_backbone_name(self, name: str | None) -> str:
        """The backbone a request means: its name, else the default; `auto` resolved now."""
        name = name or self.settings.backbone
        return resolve_auto(self.settings) if name == AUTO else name

    def backbone(self, name: str | None = None) -> Backbone:
        """The named backbone (default from settings), built once per process.

        A learned backbone whose weights are not present is refused (409, with the command that
        gets them) before anything is built or loaded; weights that are present but do not fit
        are an installation fault (503, from building it).
        """
        name = self.resolve_backbone_name(name)
        if name in CATALOGUE and name not in self._backbones:
            state = availability(name, self.settings)
            if not state.available and state.reason and state.reason.startswith(WEIGHTS_ABSENT):
                raise BackboneNotInstalled(state.refusal)
        with self._backbone_lock:
            if name in self._backbones:
                return self._backbones[name]
            try:
                backbone = create_backbone(name, **self._backbone_settings(name))
            except BackboneError as error:
                self._backbone_errors[name] = str(error)
                status = InvalidInput if "unknown backbone" in str(error) else BackboneUnavailable
                raise status(str(error)) from error
            self._backbones[name] = backbone
            self._backbone_errors.pop(name, None)
            log.info("backbone %s (version %s) ready", backbone.name, backbone.version)
            return backbone

    def _backbone_settings(self, name: str) -> dict:
        settings = self.settings
        if name not in CATALOGUE:
            return {}
        path, _ = locate(name, getattr(settings, f"{name}_checkpoint"), settings.weights_revision)
        config = getattr(settings, f"{name}_config")
        common = {"checkpoint": str(path) if path else None, "config": str(config) if config else None}
        if name == "vggt":
            return {**common, "device": settings.device}
        return {
            **common,
            "device": settings.device,
            "revision": settings.weights_revision,
            "pixel_limit": settings.pi3_pixel_limit,
            "max_views": settings.pi3_max_views,
        }

    def backbone_status(self) -> tuple[bool, str]:
        name = self.settings.backbone
        try:
            return self.backbone(name).ready()
        except (BackboneUnavailable, BackboneNotInstalled, InvalidInput) as error:
            return False, error.message

    # ---- scenes ----------------------------------------------------------------------------

    def storage_status(self) -> StorageStatus:
        """Whether scenes can be stored now (data dir writable with room; shared store caught up)."""
        problem = self.store.check_writable()
        if problem:
            return StorageStatus(False, problem, [problem])
        warnings = []
        shared = self.store.shared
        if shared is not None and shared.pending and shared.catch_up():
            where = "in the durable store, not yet in Redis" if self.store.durable else "on this replica only"
            warnings.append(f"{shared.pending} scenes are stored {where} (Redis: {shared.last_error})")
        return StorageStatus(True, "ok", warnings)

    def start_store_gc(self) -> StoreCollector | None:
        """The durable store's periodic GC, when there is a store and a limit (see store_gc.py)."""
        settings, durable = self.settings, self.store.durable
        if durable is None or not (settings.store_max_age_days or settings.store_max_gb):
            return None
        collector = StoreCollector(
            durable,
            max_age_s=settings.store_max_age_days * 86400,
            max_bytes=int(settings.store_max_gb * 2**30),
            interval_s=settings.store_gc_interval_s,
        )
        collector.start()
        return collector

    def decode(self, data: bytes, label: str) -> np.ndarray:
        return decode_image(
            data,
            max_bytes=self.settings.max_image_bytes,
            max_pixels=self.settings.max_image_pixels,
            label=label,
        )

    def scene_ids(self) -> SceneIds:
        """Per-tenant scene ids, under the configured secret or the one kept in the store."""
        with self._scene_ids_lock:
            if self._scene_ids is None:
                secret = self.settings.scene_id_secret
                if secret is not None:
                    key = secret.get_secret_value().encode()
                else:
                    try:
                        key = load_or_create_secret(self.settings.store_dir or self.settings.data_dir)
                    except OSError as error:
                        raise storage_error("read or create the scene id secret", error) from error
                self._scene_ids = SceneIds(key)
            return self._scene_ids

    async def add_scene(self, scene: SceneInput, tenant: str = DEFAULT_TENANT) -> tuple[str, bool]:
        if not 1 <= scene.num_images <= self.settings.max_images:
            raise InvalidInput(f"a scene has 1 to {self.settings.max_images} images; got {scene.num_images}")
        validate_geometry(scene)

        def save() -> tuple[str, bool]:
            scene_id = scene.content_id()  # the default tenant's id; the others' need the secret
            if tenant != DEFAULT_TENANT:
                scene_id = self.scene_ids().scene_id(tenant, scene_id)
            return self.store.save(scene, scene_id, tenant)

        return await run_cpu(save)

    # ---- reconstruction ----------------------------------------------------------------------

    async def reconstruct(
        self, scene_id: str, backbone_name: str | None = None, tenant: str = DEFAULT_TENANT
    ) -> ReconstructOutcome:
        check_scene_id(scene_id)
        info = await run_cpu(self.store.info, scene_id, tenant)  # SceneNotFound for another tenant's
        # A backbone the request names wins; else the scene is reconstructed as it was uploaded.
        backbone_name = backbone_name or (POSED_RGBD if info["kind"] == POSED_RGBD else None)
        backbone = await anyio.to_thread.run_sync(self.backbone, backbone_name)
        ready, detail = backbone.ready()
        if not ready:
            raise BackboneUnavailable(f"backbone {backbone.name} is not ready: {detail}")
        key = f"{scene_id}:{backbone.name}:{backbone.version}:in{INPUTS_VERSION}"
        started = time.perf_counter()

        hot = self._decoded.get(key)
        if hot is not None:
            return ReconstructOutcome(hot, True, False, {"cache_ms": _ms(started)})
        payload = await self.cache.get(key)
        cached = None if payload is None else await run_cpu(_readable, payload, key)
        if cached is not None:
            self._remember(key, cached)
            return ReconstructOutcome(cached, True, False, {"cache_ms": _ms(started)})

        async def compute() -> tuple[Reconstruction, dict[str, float]]:
            reconstruction, timings = await self._run_backbone(scene_id, backbone, tenant)
            await self.cache.set(key, await run_cpu(reconstruction.to_bytes))
            return reconstruction, timings

        async def load(payload: bytes) -> tuple[Reconstruction, dict[str, float]]:
            readable = await run_cpu(_readable, payload, key)
            return (readable, {}) if readable is not None else await compute()

        result, joined = await self.jobs.run(key, compute, load)
        reconstruction, timings = result.value
        self._remember(key, reconstruction)
        if joined or not result.computed_here:  # waited for this process's or another replica's job
            return ReconstructOutcome(reconstruction, False, True, {**timings, "waited_ms": _ms(started)})
        return ReconstructOutcome(reconstruction, False, False, {**timings, "total_ms": _ms(started)})

    async def _run_backbone(
        self, scene_id: str, backbone: Backbone, tenant: str
    ) -> tuple[Reconstruction, dict[str, float]]:
        def work() -> tuple[Reconstruction, dict[str, float]]:
            started = time.perf_counter()
            scene = self.store.load(scene_id, self.decode, tenant)
            loaded = time.perf_counter()
            options = {}
            known = view_intrinsics(scene)
            if backbone.name == "posed-rgbd":
                options = {
                    "depths": scene.depths,
                    "extrinsics": scene.extrinsics,
                    "intrinsics": scene.intrinsics,
                }
            elif backbone.accepts_intrinsics and known.known_views:
                options = {"intrinsics": known.intrinsics, "intrinsics_sources": known.sources}
            if backbone.accepts_posed_depth and scene.depths is not None and scene.extrinsics is not None:
                options.update(depths=scene.depths, extrinsics=scene.extrinsics)
            try:
                reconstruction = backbone.reconstruct(scene.images, **options)
            except BackboneLoadError as error:
                raise BackboneUnavailable(
                    f"backbone {backbone.name} cannot load its weights: {error}"
                ) from error
            except BackboneError as error:
                raise InvalidInput(
                    f"backbone {backbone.name} cannot reconstruct this scene: {error}"
                ) from error
            reconstruction.warnings.extend(known.warnings)
            if known.known_views and backbone.name != "posed-rgbd" and not backbone.accepts_intrinsics:
                views = ", ".join(str(view + 1) for view in known.known_views)
                reconstruction.warnings.append(
                    f"{backbone.name} predicts its own intrinsics: the uploaded or EXIF intrinsics of "
                    f"view(s) {views} were not used"
                )
            return reconstruction, {"load_ms": (loaded - started) * 1e3, "reconstruct_ms": _ms(loaded)}

        return await run_in_daemon_thread(work, name=f"reconstruct {scene_id}")

    def _remember(self, key: str, reconstruction: Reconstruction) -> None:
        self._decoded[key] = reconstruction
        self._decoded.move_to_end(key)
        while len(self._decoded) > 4:
            self._decoded.popitem(last=False)

    # ---- tools on a reconstruction -----------------------------------------------------------

    async def render(
        self,
        scene_id: str,
        extrinsic: list[list[float]],
        width: int,
        height: int,
        zoom_out: float,
        fmt: str,
        backbone: str | None,
        tenant: str = DEFAULT_TENANT,
    ) -> bytes:
        limit = self.settings.max_render_side
        if width > limit or height > limit:
            raise InvalidInput(f"render size {width}x{height} exceeds the limit of {limit} pixels a side")
        pose = _validated_pose(extrinsic)
        outcome = await self.reconstruct(scene_id, backbone, tenant)
        recon = outcome.reconstruction

        def work() -> bytes:
            image = synthesize_novel_view(recon, pose, width=width, height=height, zoom_out=zoom_out)
            return encode_image(image, fmt)

        return await anyio.to_thread.run_sync(work)

    async def render_warning(self, scene_id: str, backbone: str | None, tenant: str) -> str | None:
        """What a render of this scene should say about its poses: the focal hypothesis it uses
        when the focal is unknown and the views cannot fix it, else None."""
        hypotheses = (await self.reconstruct(scene_id, backbone, tenant)).reconstruction.focal_hypotheses
        if hypotheses is None:
            return None
        return (
            f"rendered at the central focal hypothesis ({hypotheses.central_fov_deg:.0f} degrees horizontal "
            "field of view): the focal length is unknown and the views cannot fix it, so other "
            "hypotheses would place the cameras differently"
        )

    async def camera_motion(
        self,
        scene_id: str,
        pairs: list[tuple[int, int]] | None,
        backbone: str | None,
        target: MotionTarget | None = None,
        tenant: str = DEFAULT_TENANT,
    ) -> tuple[Reconstruction, list[CameraMotion | UnknownMotion], float]:
        """Per pair a description or why there is none; (reconstruction, motions, scene scale)."""
        limit = self.settings.max_motion_pairs
        if pairs is not None and len(pairs) > limit:
            raise InvalidInput(f"{len(pairs)} view pairs; one camera-motion request takes at most {limit}")
        outcome = await self.reconstruct(scene_id, backbone, tenant)
        recon = outcome.reconstruction
        motions, scale = await run_cpu(describe_scene_motion, recon, pairs, target)
        return recon, motions, scale


def _durable_store(settings: ReconSettings) -> tuple[DurableStore | None, str | None]:
    """The store of record when one is configured, or why it cannot be used (for /readyz, uploads)."""
    if settings.store_dir is None:
        return None, None
    try:
        return DurableStore(settings.store_dir), None
    except OSError as error:
        return None, storage_error("create the durable store", error).message


def _readable(payload: bytes, key: str) -> Reconstruction | None:
    """A cached reconstruction, or None (a miss) when this code cannot read it: a replica of
    another version sharing the Redis wrote it under the same key; recomputing replaces it."""
    try:
        return Reconstruction.from_bytes(payload)
    except ReconstructionFormatError as error:
        log.warning("cached reconstruction %s is unreadable here (%s): reconstructing", key, error)
        return None


def _validated_pose(extrinsic: list[list[float]]) -> np.ndarray:
    try:
        pose = np.asarray(extrinsic, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise InvalidInput(f"extrinsic must be a 3x4 or 4x4 matrix of numbers: {error}") from error
    try:
        validate_extrinsic(pose)
    except ValueError as error:
        raise InvalidInput(f"malformed extrinsic: {error}") from error
    return pose[:3, :4]


def _ms(since: float) -> float:
    return (time.perf_counter() - since) * 1e3
