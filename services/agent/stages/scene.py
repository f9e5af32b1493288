"""The scene of a solve: the photos uploaded (or an existing scene looked up), then reconstructed."""

from __future__ import annotations

import numpy as np
from PIL import Image

from services.agent.errors import SolveError
from shared.imaging.codecs import decode_image, encode_image
from shared.wire.client import ReconClient, ServiceError
from shared.wire.schemas import ReconstructionStep, SceneStep
from shared.wire.settings import AgentSettings

ANSWER_IMAGE_SIDE = 1024  # images shown to the models are downscaled to this longest side


def upload(
    step: SceneStep, image_files: list[bytes] | None, recon: ReconClient, settings: AgentSettings
) -> SceneStep:
    """Upload the images (or look up `step.scene_id`) and keep PNGs of them for the models."""
    if image_files and step.scene_id:
        raise SolveError(422, "send either images or a scene_id, not both")
    if image_files:
        if len(image_files) > settings.max_images:
            raise SolveError(422, f"{len(image_files)} images; at most {settings.max_images}")
        # Decode first: an unreadable image is reported by its number (1-based, as on the page).
        step.input_pngs = [_model_png(blob, i, settings) for i, blob in enumerate(image_files)]
        step.scene_id = recon.upload_scene(image_files).scene_id
    elif step.scene_id:
        info = recon.scene_info(step.scene_id)
        stored = [recon.scene_image(step.scene_id, i) for i in range(info.num_images)]
        step.input_pngs = [_model_png(blob, i, settings) for i, blob in enumerate(stored)]
    else:
        raise SolveError(422, "send images (multipart 'images' or JSON base64) or an existing scene_id")
    step.num_images = len(step.input_pngs)
    return step


def _model_png(blob: bytes, index: int, settings: AgentSettings) -> bytes:
    rgb = decode_image(blob, max_bytes=settings.max_image_bytes, max_pixels=10**9, label=f"image {index + 1}")
    height, width = rgb.shape[:2]
    scale = ANSWER_IMAGE_SIDE / max(height, width)
    if scale < 1:
        size = (max(1, round(width * scale)), max(1, round(height * scale)))
        rgb = np.asarray(Image.fromarray(rgb).resize(size, Image.Resampling.LANCZOS))
    return encode_image(rgb, "png")


def reconstruct(step: ReconstructionStep, scene_id: str, recon: ReconClient) -> ReconstructionStep:
    """Reconstruct first: the program's own reconstruct() is then a cache hit.

    Input the backbone cannot use (a 422) is the step's `error`, not the solve's: the photos are
    then answered from alone when an answer model is set.
    """
    try:
        summary = recon.reconstruct(scene_id, step.requested_backbone)
    except ServiceError as error:
        if error.status_code != 422:
            raise
        menu = recon.backbones()
        used = step.requested_backbone or menu.get("default", "default")
        if used == "auto":  # say which backbone auto stood for
            used = menu.get("auto", used)
        step.backbone = used
        step.error = f"the {used} backbone could not reconstruct the scene: {error.message}"
        return step
    step.cameras = summary.cameras
    step.backbone = summary.backbone
    step.views_placed = sum(camera.registered for camera in summary.cameras)
    step.num_views = len(summary.cameras)
    step.num_points = summary.num_points
    step.cached = bool(summary.cached)
    return step


__all__ = ["ANSWER_IMAGE_SIDE", "reconstruct", "upload"]
