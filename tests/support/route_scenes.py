"""``bench.route``'s two-room captures for tests: the scene, its rendered views (exact depth) and
the posed RGB-D reconstruction of them (cameras: 3x4 camera-from-world, OpenCV axes, pixels)."""

from __future__ import annotations

from shared.geometry.backprojection import reconstruction_from_rgbd
from shared.geometry.reconstruction import Reconstruction
from shared.synthetic.two_rooms import TwoRoomScene, generate_two_rooms

TUNING_SEED = 23  # bench.route's tuning seed: scene i is generate_two_rooms(23 * 1000 + i, ...)
RADIUS = 0.25
BAND = (0.05, 0.5)


def tuning_capture(index: int, kind: str) -> tuple[TwoRoomScene, list, Reconstruction]:
    """Tuning scene ``index`` of this kind (``varied``, as the bench draws it), its views, and their
    posed RGB-D reconstruction."""
    two = generate_two_rooms(TUNING_SEED * 1000 + index, kind, radius=RADIUS, band=BAND, varied=True)
    views = two.render()
    recon = reconstruction_from_rgbd(
        [v.rgb for v in views], [v.depth for v in views], two.extrinsics, [two.intrinsic] * len(views)
    )
    return two, views, recon
