"""The sandbox's pySpatial calls, served by the reconstruction service over HTTP.

Point clouds never cross the wire: the agent only sees cameras, sentences and rendered PNGs.
"""

from __future__ import annotations

import numpy as np

from shared.geometry.reconstruction import Reconstruction
from shared.navigation import locate, plan_route
from shared.wire.client import ReconClient


class ReconToolProvider:
    """Parent-side tools of one solve: one scene, one backbone, the input images as PNG."""

    def __init__(
        self, client: ReconClient, scene_id: str, backbone: str | None, input_pngs: list[bytes]
    ) -> None:
        self.client = client
        self.scene_id = scene_id
        self.backbone = backbone
        self.input_pngs = input_pngs
        self.backbone_used: str | None = None
        # What each rendered PNG was rendered from, so the clue can say so (keyed by its bytes).
        self.rendered_poses: dict[bytes, tuple[list[list[float]], int, int]] = {}
        self.view_extrinsics: list[list[list[float]]] = []  # the input views' poses (NaN: not placed)
        self._downloaded: Reconstruction | None = None

    def reconstruct(self) -> dict:
        summary = self.client.reconstruct(self.scene_id, self.backbone)
        self.backbone_used = summary.backbone
        nan_pose = np.full((3, 4), np.nan).tolist()  # unregistered views: no pose to invent
        nan_intrinsic = np.full((3, 3), np.nan).tolist()
        self.view_extrinsics = [c.extrinsic if c.registered else nan_pose for c in summary.cameras]
        return {
            "extrinsics": list(self.view_extrinsics),
            "intrinsics": [nan_intrinsic if c.intrinsic is None else c.intrinsic for c in summary.cameras],
            "image_sizes": [[c.width, c.height] for c in summary.cameras],
            "registered": [c.registered for c in summary.cameras],
            "up": summary.up,
            "warnings": summary.warnings,
            "units": summary.units,
        }

    def describe_camera_motion(self, pair: tuple[int, int] | None = None) -> list[str]:
        """One sentence per pair: its motion, or that it is unknown and why (never fails for one view).
        `pair` (1-based from and to view): that pair's sentence alone; None: the consecutive pairs."""
        views = {"from_view": pair[0], "to_view": pair[1]} if pair else {}
        response = self.client.camera_motion(self.scene_id, backbone=self.backbone, **views)
        return [motion.sentence for motion in response.motions]

    def synthesize_novel_view(self, extrinsic: list[list[float]], width: int, height: int) -> bytes:
        png = self.client.render(self.scene_id, extrinsic, width=width, height=height, backbone=self.backbone)
        self.rendered_poses[png] = (extrinsic, width, height)
        return png

    def input_image(self, index: int) -> bytes:
        if not 0 <= index < len(self.input_pngs):
            raise IndexError(f"the scene has images 0..{len(self.input_pngs) - 1}")
        return self.input_pngs[index]

    def _reconstruction(self) -> Reconstruction:
        if self._downloaded is None:
            self._downloaded = self.client.reconstruction(self.scene_id, self.backbone)
        return self._downloaded

    def locate(self, view: int, u: float, v: float) -> dict:
        found = locate(self._reconstruction(), view, u, v)
        return {"point": None if found.point is None else found.point.tolist(), "reason": found.reason}

    def plan_route(self, start_view: int, goal: list[float], robot_radius: float) -> dict:
        plan = plan_route(
            self._reconstruction(), start_view, np.asarray(goal, float), robot_radius=robot_radius
        )
        return {**plan.to_dict(), "summary": route_summary(plan)}


def route_summary(plan) -> str:
    """The plan in words for a reader: its sentences, or that there is none and why."""
    if not plan.reachable:
        return f"No collision-free route: {plan.reason}."
    if not plan.sentences:
        return "The robot is already at the goal."
    unit = "m" if plan.units == "metres" else "scene units"
    return ". ".join(plan.sentences) + f". The route is {plan.length:.2f} {unit} long."
