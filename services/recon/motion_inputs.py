"""What camera motion needs from a reconstruction: which views have a trustworthy pose, and the scale.

Views are numbered from 1 in the reasons, as in the motion sentences they end up in.
"""

from __future__ import annotations

import numpy as np

from shared.geometry.camera_motion import CameraMotion, UnknownMotion, robust_extent, unknown_motion
from shared.geometry.motion_determinacy import FOCAL_HYPOTHESIS_REASON
from shared.geometry.poses import validate_extrinsic
from shared.geometry.reconstruction import Reconstruction

_TINY = 1e-9


def view_pose_problems(recon: Reconstruction) -> list[str | None]:
    """Per view, why its pose cannot be used for motion (not registered, not a valid pose, flagged
    uncertain by the backbone's verification), or None."""
    problems: list[str | None] = []
    for index in range(recon.num_views):
        if not recon.registered[index]:
            problems.append(f"view {index + 1} could not be registered by the {recon.backbone} backbone")
            continue
        try:  # the same check the motion maths applies, so a usable view never fails there
            validate_extrinsic(recon.extrinsics[index])
        except ValueError as error:
            problems.append(f"view {index + 1} has no valid pose ({error})")
            continue
        uncertain = recon.view_confidence[index].uncertain_reason if recon.view_confidence else None
        if uncertain and uncertain.startswith(FOCAL_HYPOTHESIS_REASON) and recon.focal_hypotheses:
            uncertain = None  # its pairs are described over the focal hypotheses instead
        # A motion sentence states the step and the turn together: a half-known pose gives none.
        problems.append(f"view {index + 1}'s pose is not certain ({uncertain})" if uncertain else None)
    return problems


def pair_pose_problems(recon: Reconstruction) -> dict[tuple[int, int], str]:
    """Pairs of usable views whose relative pose the backbone flagged uncertain, with why.

    Both views may be fine alone while their relative pose is not (a short baseline through a
    narrow lens, two models explaining their matches alike): no motion sentence for such a pair."""
    return {
        (pair.first, pair.second): (
            f"the relative pose of views {pair.first + 1} and {pair.second + 1} is not certain "
            f"({pair.uncertain_reason})"
        )
        for pair in recon.pair_confidence
        if pair.uncertain_reason
    }


def without_uncertain_pairs(
    motions: list[CameraMotion | UnknownMotion], recon: Reconstruction
) -> list[CameraMotion | UnknownMotion]:
    """The motions, with those of pairs flagged uncertain replaced by why they are not given."""
    uncertain = pair_pose_problems(recon)
    result = []
    for motion in motions:
        key = (min(motion.from_view, motion.to_view), max(motion.from_view, motion.to_view))
        if motion.described and key in uncertain:
            motion = unknown_motion(motion.from_view, motion.to_view, uncertain[key])
        result.append(motion)
    return result


def motion_scene_scale(recon: Reconstruction, usable: list[int]) -> float:
    """The size against which a step counts as movement: the robust extent of the points.

    With two cameras the centres alone cannot tell a small drift from a real step, so the points
    decide; without points the usable camera centres do, and 1.0 when they coincide.
    """
    extent = robust_extent(recon.points) if recon.num_points else 0.0
    if extent > _TINY and np.isfinite(extent):
        return extent
    centers = recon.camera_centers()[usable] if usable else np.zeros((0, 3))
    extent = robust_extent(centers) if len(centers) else 0.0
    return extent if extent > _TINY and np.isfinite(extent) else 1.0


def pixel_point(recon: Reconstruction, view: int, u: float, v: float) -> np.ndarray | None:
    """The surface an object at pixel (u, v) of `view` lies on: the nearest reconstructed points there.

    Of the points projecting within a small radius (2% of the image's longer side, at least 4 px),
    the nearest quarter by depth is taken (farther ones are behind the object) and their median
    returned; None when no point projects there.
    """
    rotation, translation = recon.extrinsics[view][:3, :3], recon.extrinsics[view][:3, 3]
    camera_points = recon.points.astype(np.float64) @ rotation.T + translation
    depth = camera_points[:, 2]
    front = depth > _TINY
    if not np.any(front):
        return None
    projected = camera_points[front] @ recon.intrinsics[view].T
    pixels = projected[:, :2] / projected[:, 2:3]
    radius = max(4.0, 0.02 * float(max(recon.image_sizes[view])))
    near = np.linalg.norm(pixels - np.array([u, v]), axis=1) <= radius
    if not np.any(near):
        return None
    candidates = recon.points[front][near].astype(np.float64)
    order = np.argsort(depth[front][near])
    nearest = candidates[order[: max(1, len(order) // 4)]]
    return np.median(nearest, axis=0)


def scene_centre(recon: Reconstruction, usable: list[int]) -> np.ndarray:
    """The median of the points (of the usable camera centres when there are none)."""
    if recon.num_points:
        return np.median(recon.points.astype(np.float64), axis=0)
    return np.median(recon.camera_centers()[usable], axis=0)
