"""Metres per scene unit for a plan: the backbone's metric scale, the robot's camera height, or a guess.

A reconstruction in scene units becomes metric when the robot says how high its camera is: the
start camera's height above the fitted floor plane (scene units) over that height (metres). The
floor fit's residual under the start view says how far that plane can be trusted there. A metric
reconstruction needs no height; given one too, the ratio of the two scales is reported as a check.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from shared.navigation.floor import Floor

ASSUMED_CAMERA_HEIGHT_M = 1.5
_RESIDUAL_BAND = 0.05  # floor points: within this share of the camera height of the plane
_RESIDUAL_REACH = 2.0  # ... and within this many camera heights of the start, along the floor
_CHECK_TOLERANCE = 0.1  # a metric scale and a camera height that disagree by more are warned about


@dataclass(frozen=True)
class Scale:
    per_metre: float  # scene units per metre
    units: str  # "metres" or "scene units": the units of the moves
    scale_from: str  # "metric reconstruction", "camera height" or "assumed camera height"
    floor_residual_m: float | None = None  # RMS of the floor points' heights under the start view
    check: float | None = None  # metric and a camera height: metric height / given height
    warnings: list[str] = field(default_factory=list)


def floor_residual(floor: Floor, points: np.ndarray, centre: np.ndarray) -> float:
    """RMS height (scene units) of the floor points near the floor below the start camera."""
    camera_height = float(floor.height(centre)[0])
    heights = floor.height(points)
    on_floor = np.abs(heights) <= _RESIDUAL_BAND * camera_height
    near = np.linalg.norm(floor.to_plane(points) - floor.to_plane(centre), axis=1) <= (
        _RESIDUAL_REACH * camera_height
    )
    chosen = heights[on_floor & near] if np.count_nonzero(on_floor & near) >= 10 else heights[on_floor]
    return float(np.sqrt(np.mean(chosen**2))) if len(chosen) else float("nan")


def plan_scale(
    metric: bool, floor: Floor, points: np.ndarray, centre: np.ndarray, camera_height_m: float | None
) -> Scale:
    """The scale of a plan whose start camera is at ``centre`` (world) over ``floor``."""
    height = float(floor.height(centre)[0])
    if height <= 0:
        raise ValueError("the start camera is not above the estimated floor")
    residual = floor_residual(floor, points, centre)
    if metric:
        check = None if camera_height_m is None else height / camera_height_m
        warnings = []
        if check is not None and abs(check - 1.0) > _CHECK_TOLERANCE:
            warnings.append(
                f"the metric reconstruction puts the start camera {height:.2f} m above the floor, but "
                f"the robot's camera is {camera_height_m:.2f} m high (ratio {check:.2f}): one is off"
            )
        return Scale(1.0, "metres", "metric reconstruction", residual, check, warnings)
    if camera_height_m is not None:
        per_metre = height / camera_height_m
        return Scale(per_metre, "metres", "camera height", residual / per_metre)
    warning = (
        "the reconstruction has no metric scale: distances are in scene units, and the robot's size "
        f"was scaled assuming the start camera was {ASSUMED_CAMERA_HEIGHT_M} m above the floor "
        "(give the robot's camera height for metres)"
    )
    per_metre = height / ASSUMED_CAMERA_HEIGHT_M
    return Scale(per_metre, "scene units", "assumed camera height", residual / per_metre, None, [warning])
