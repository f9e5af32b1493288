"""Camera motion of a reconstruction's pairs: what `/v1/camera-motion` answers, in one function.

The service's route and the benches that score its sentences (bench.determinacy_synthetic) call
`describe_scene_motion`, so a bench scores exactly what a user gets. View indices are 0-based;
the sentences and reasons count views from 1.
"""

from __future__ import annotations

import numpy as np

from services.recon.errors import InvalidInput
from services.recon.motion_inputs import (
    motion_scene_scale,
    pixel_point,
    scene_centre,
    view_pose_problems,
    without_uncertain_pairs,
)
from shared.geometry.camera_motion import CameraMotion, UnknownMotion, default_pairs, describe_pairs
from shared.geometry.motion_determinacy import with_motion_over_focal
from shared.geometry.poses import estimate_up_axis, up_is_reliable
from shared.geometry.reconstruction import Reconstruction
from shared.wire.schemas import MotionTarget


def describe_scene_motion(
    recon: Reconstruction, pairs: list[tuple[int, int]] | None, target: MotionTarget | None = None
) -> tuple[list[CameraMotion | UnknownMotion], float]:
    """The motion of each pair (the default pairs when None) and the scene scale the distances
    use. Flagged pairs and views get why not; over an unknown focal, what every hypothesis gives."""
    views = recon.num_views
    if views < 2:
        raise InvalidInput("camera motion needs at least two views; this scene has one")
    for pair in pairs or []:  # indices here; the request numbered them from 1
        for view in pair:
            if not 0 <= view < views:
                raise InvalidInput(f"view {view + 1} does not exist: the scene has views 1..{views}")
    problems = view_pose_problems(recon)
    usable = [index for index, problem in enumerate(problems) if problem is None]
    up = estimate_up_axis(recon.extrinsics[usable]) if usable else None
    scale = motion_scene_scale(recon, usable)
    aim = _target_point(recon, target, usable, problems)
    if pairs is None and recon.focal_hypotheses is not None:
        # Unknown focal: every pair that has hypotheses gets its sentence of what they all share,
        # since the poses alone (the central hypothesis) cannot say it for any other pair.
        solved = [(p.first, p.second) for p in recon.focal_hypotheses.pairs]
        pairs = sorted({*default_pairs(views, [p is None for p in problems]), *solved})
    motions = describe_pairs(
        recon.extrinsics,
        problems,
        pairs=pairs,
        up=up,
        scene_scale=scale,
        units=recon.units or "relative",
        # The up above is estimated: the gravity frame is said only when the headings fix it.
        up_reliable=bool(usable) and up_is_reliable(recon.extrinsics[usable]),
        **aim,
    )
    motions = without_uncertain_pairs(motions, recon)
    return [with_motion_over_focal(motion, recon.focal_hypotheses) for motion in motions], scale


def pair_motion(recon: Reconstruction, pair: tuple[int, int]) -> CameraMotion | UnknownMotion:
    """One pair's motion (0-based view indices), as /v1/camera-motion gives it."""
    (motion,), _ = describe_scene_motion(recon, [pair])
    return motion


def _target_point(
    recon: Reconstruction, target: MotionTarget | None, usable: list[int], problems: list[str | None]
) -> dict[str, object]:
    """The request's target as describe_pairs' `target` and `target_name` ({} without one)."""
    if target is None:
        return {}
    chosen = [target.point is not None, target.pixel is not None, target.scene_centre]
    if sum(chosen) != 1:
        raise InvalidInput("a camera-motion target is exactly one of point, pixel or scene_centre")
    if target.point is not None:
        return {
            "target": np.asarray(target.point, dtype=np.float64),
            "target_name": target.name or "the target point",
        }
    if target.scene_centre:
        return {"target": scene_centre(recon, usable), "target_name": target.name or "the scene's centre"}
    pixel = target.pixel
    assert pixel is not None
    index = pixel.view - 1  # the request numbers views from 1
    if index >= recon.num_views or problems[index] is not None:
        why = problems[index] if index < recon.num_views else f"the scene has views 1..{recon.num_views}"
        raise InvalidInput(f"the target pixel's view {pixel.view} has no usable pose: {why}")
    point = pixel_point(recon, index, pixel.u, pixel.v)
    if point is None:
        raise InvalidInput(
            f"no reconstructed point lies at pixel ({pixel.u:g}, {pixel.v:g}) of view {pixel.view}"
        )
    name = target.name or f"the object at pixel ({pixel.u:g}, {pixel.v:g}) of view {pixel.view}"
    return {"target": point, "target_name": name}
