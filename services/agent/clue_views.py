"""Say where each clue image came from: the pose it was rendered from, or which input photo it is."""

from __future__ import annotations

import io

from PIL import Image

from services.agent.recon_tools import ReconToolProvider
from shared.wire.schemas import CameraInfo, ClueView


def clue_views(
    clue_images: list[bytes], tools: ReconToolProvider, cameras: list[CameraInfo]
) -> list[ClueView]:
    """One ClueView per clue image; `cameras` are the reconstruction's, one per input photo."""
    views = []
    for png in clue_images:
        with Image.open(io.BytesIO(png)) as image:  # header only
            width, height = image.size
        if png in tools.rendered_poses:
            extrinsic, _, _ = tools.rendered_poses[png]
            views.append(ClueView(source="rendered", extrinsic=extrinsic, width=width, height=height))
            continue
        index = next((i for i, own in enumerate(tools.input_pngs) if own == png), None)
        camera = cameras[index] if index is not None and index < len(cameras) else None
        views.append(
            ClueView(
                source="input",
                input_view=None if index is None else index + 1,
                extrinsic=camera.extrinsic if camera is not None else None,
                width=width,
                height=height,
            )
        )
    return views
