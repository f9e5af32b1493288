"""Verification of a rotation-only model: the same bar as a model with points.

A set of views taken as turning about one point has no triangulated points, so the checks of
verification.py (inliers, spread, reprojection, cheirality, agreement with the pairs) are made on
the matched rays instead: each match of a view to a placed partner is transferred by the model's
relative rotation, x2 ~ K2 R K1^-1 x1, and must land within ROTATION_THRESHOLD_PX, in front of the
camera. Two more checks belong to this model alone: the matches must not fit a move with
parallax about as well, and the turn must explain nearly all the matches that fit an epipolar
geometry. An object on a turntable seen 15 degrees apart with few features fits "turned by a
degree" as well as the true orbit (templeRing 20-22 at 160x120: 30 rays, 16 degrees off), and
then the words "the views only rotate about one point" would be false.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.geometry.reconstruction import ViewConfidence

from .geometry import bearings, rotation_angle_deg
from .two_view import ROTATION_THRESHOLD_PX, TwoViewGeometry
from .verification import GRID, disagreement_with_pairs, rejection_reason

# The essential model is a real rival when it explains this share of what the rotation explains
# with rays meeting at a useful angle, and puts the second view elsewhere than the rotation does.
RIVAL_SHARE = 0.8
RIVAL_PARALLAX_DEG = 2.0
RIVAL_ROTATION_GAP_DEG = 2.0  # more than "a few degrees" of doubt on the rotation: refuse
# A true turn explains nearly every match an epipolar geometry explains (a turn is one); when it
# leaves many out, the camera moved too, whatever the essential model's own fit says (templeRing
# 1-2 at 320x240: 152 of 270, and the essential fit, degenerate, keeps 2 in front of the views).
EXPLAINED_SHARE = 0.8


@dataclass(frozen=True)
class _Transfer:
    pixels: np.ndarray  # (N, 2) the view's own keypoints
    errors: np.ndarray  # (N,) transfer error of the partner's keypoint into this view, pixels
    ahead: np.ndarray  # (N,) whether the rotated partner ray points in front of this camera


def rotation_model_reasons(
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    extrinsics: dict[int, np.ndarray],
    pairs: dict[tuple[int, int], TwoViewGeometry],
) -> tuple[dict[int, ViewConfidence], dict[int, str]]:
    """Per placed view its confidence under the rotation model, and the reason for each refusal."""
    confidence, reasons = {}, {}
    for view in extrinsics:
        transfer = _transfer_into(view, keypoints, intrinsics, extrinsics, pairs)
        confidence[view] = _confidence(transfer, image_sizes[view])
        reason = rejection_reason(confidence[view], 1.0) or disagreement_with_pairs(view, extrinsics, pairs)
        reason = reason or _rival_reason(view, extrinsics, pairs)
        if reason is not None:
            reasons[view] = reason
    return confidence, reasons


def _transfer_into(
    view: int,
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    extrinsics: dict[int, np.ndarray],
    pairs: dict[tuple[int, int], TwoViewGeometry],
) -> _Transfer:
    pixels, errors, ahead = [], [], []
    for (first, second), pair in pairs.items():
        if view not in (first, second) or first not in extrinsics or second not in extrinsics:
            continue
        other, own_column = (second, 0) if first == view else (first, 1)
        own = keypoints[view][pair.matches[:, own_column]]
        rays = bearings(keypoints[other][pair.matches[:, 1 - own_column]], intrinsics[other])
        # partner camera -> world -> this camera; both centres are the same point
        relative = extrinsics[view][:, :3] @ extrinsics[other][:, :3].T
        moved = rays @ relative.T
        in_front = moved[:, 2] > 1e-6
        depth = np.where(in_front, moved[:, 2], 1.0)
        predicted = moved[:, :2] / depth[:, None] * np.diag(intrinsics[view])[:2] + intrinsics[view][:2, 2]
        pixels.append(own)
        errors.append(np.where(in_front, np.linalg.norm(predicted - own, axis=1), np.inf))
        ahead.append(in_front)
    if not pixels:
        return _Transfer(np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=bool))
    return _Transfer(np.concatenate(pixels), np.concatenate(errors), np.concatenate(ahead))


def _confidence(transfer: _Transfer, image_size: tuple[int, int]) -> ViewConfidence:
    good = transfer.ahead & (transfer.errors < ROTATION_THRESHOLD_PX)
    width, height = image_size
    cells = {
        (min(int(u / width * GRID), GRID - 1), min(int(v / height * GRID), GRID - 1))
        for u, v in transfer.pixels[good]
    }
    return ViewConfidence(
        inliers=int(good.sum()),
        spread=len(cells) / GRID**2,
        reprojection_error_px=float(np.median(transfer.errors[good])) if good.any() else float("nan"),
        positive_depth_fraction=float(transfer.ahead.mean()) if len(transfer.ahead) else float("nan"),
    )


def _rival_reason(
    view: int, extrinsics: dict[int, np.ndarray], pairs: dict[tuple[int, int], TwoViewGeometry]
) -> str | None:
    """A reason when every placed partner's matches fit a move with parallax about as well."""
    rivalled, other_views = [], []
    for (first, second), pair in pairs.items():
        if view not in (first, second) or first not in extrinsics or second not in extrinsics:
            continue
        rivals = pair.rivals
        other_views.append(second if first == view else first)
        rotation_count = max(rivals.rotation_inliers, len(pair.matches))
        if rotation_count < EXPLAINED_SHARE * rivals.epipolar_inliers:
            rivalled.append((other_views[-1], rivals, rotation_count, None))
            continue
        if rivals.essential_rotation is None or rivals.essential_inliers < RIVAL_SHARE * rotation_count:
            continue
        gap = rotation_angle_deg(rivals.essential_rotation @ pair.rotation.T)
        if rivals.essential_parallax_deg >= RIVAL_PARALLAX_DEG and gap > RIVAL_ROTATION_GAP_DEG:
            rivalled.append((other_views[-1], rivals, rotation_count, gap))
    if not rivalled or len(rivalled) < len(other_views):
        return None
    other, rivals, rotation_count, gap = max(rivalled, key=lambda item: item[2])
    if gap is None:
        return (
            f"a turn in place explains only {rotation_count} of the {rivals.epipolar_inliers} matches "
            f"to view {other + 1} that fit an epipolar geometry: it may not only have turned"
        )
    return (
        f"its matches to view {other + 1} fit a turn in place ({rotation_count} rays) and a move with "
        f"{rivals.essential_parallax_deg:.0f} degrees of parallax ({rivals.essential_inliers}) about "
        f"equally well, and the two rotations differ by {gap:.0f} degrees: it may not only have turned"
    )
