"""How far each point's height above the fitted floor can be trusted.

Measured depth (posed RGB-D) puts the floor's points on its plane. A photo-only reconstruction's
points scatter about it, and more the farther they lie from the cameras that saw them: a
triangulated point's depth error grows with the square of its distance, and a ray that grazes the
floor turns it into a height error in proportion to camera height / distance, so the height error
grows in proportion to the distance; a small residual tilt of the fitted plane does too. Heights
within that scatter cannot tell the floor from a low thing standing on it.

The scatter is measured below the plane, where nothing stands: every point there is the floor's
noise (or the fit's tilt). Its spread, per unit of distance from the nearest camera that frames the
point, is the floor fit's residual grown with distance; posed RGB-D has none, and its heights keep
the robot's own floor tolerance and clearance.
"""

from __future__ import annotations

import numpy as np

from shared.navigation.floor import Floor, estimate_floor, floor_axes

# Points below the plane by more than this share of their distance to the camera (about 5.7 degrees
# below the plane as seen from the camera's height) are not the floor's noise (a step down, a
# second floor seen through a stair): they are left out of the spread.
_NOISE_SLOPE_LIMIT = 0.1
_MIN_BELOW = 20  # fewer points below the plane measure no spread: the heights are taken as exact
_MAD_TO_SIGMA = 1.4826  # a normal spread's standard deviation over its median absolute deviation
# A floor point's height lies within this many standard deviations of the plane. A photo-only cloud
# has 10^4-10^5 floor points; beyond 3 sigma lie 1 in 370 of them, enough for two to share a cell
# (an obstacle); beyond 4, 1 in 16,000.
SIGMAS = 4.0
# heights scattering less than this share of the cameras' height (1.5 cm at 1.5 m, half the robot's
# 3 cm floor tolerance) are exact: their plane is kept and nothing is tolerated
_EXACT_SHARE = 0.01
_REFITS = 3
# A refit refines the voted floor (tuning refits moved its normal 0.2-0.8 degrees); one that swings it
# further has fitted another plane (a tuning scene whose heights scatter 6 % of their distance: 26
# degrees, cameras of one height put 0.3-1.8 m above it).
_MAX_REFIT_TILT_DEG = 2.0
_SAMPLE = 20_000  # points whose spread tells whether the heights scatter at all
# A pixel with no point of its own is placed on the floor when the points around it (within this
# share of the image's larger side, 32 px of 320; at least this many) that are nearer the camera
# than that floor point are floor (this share of them: the far ones scatter).
_PIXEL_REACH = 0.1
_FLOOR_NEIGHBOURS = 5
_FLOOR_SHARE = 0.8
_FLOOR_BAND = 0.02  # of the camera's height: exact heights within this are floor (3 cm at 1.5 m)


def viewing_distance(points: np.ndarray, extrinsics: np.ndarray, intrinsics: np.ndarray, sizes) -> np.ndarray:
    """(N,) distance from each world point to the nearest camera that frames it (in front, inside
    its image); the nearest camera at all where none frames it. Cameras are camera-from-world
    [R|t] (OpenCV axes), intrinsics in the photo's pixels, ``sizes`` (V, 2) width, height."""
    points = np.asarray(points, np.float64).reshape(-1, 3)
    nearest = np.full(len(points), np.inf)
    framed = np.full(len(points), np.inf)
    for pose, intrinsic, (width, height) in zip(extrinsics, intrinsics, sizes, strict=True):
        centre = -pose[:, :3].T @ pose[:, 3]
        distance = np.linalg.norm(points - centre, axis=1)
        nearest = np.minimum(nearest, distance)
        in_camera = points @ pose[:, :3].T + pose[:, 3]
        front = in_camera[:, 2] > 1e-9
        pixels = in_camera[front] @ np.asarray(intrinsic, np.float64).T
        pixels = pixels[:, :2] / pixels[:, 2:]
        inside = np.zeros(len(points), bool)
        inside[front] = (
            (pixels[:, 0] >= -0.5)
            & (pixels[:, 1] >= -0.5)
            & (pixels[:, 0] < width - 0.5)
            & (pixels[:, 1] < height - 0.5)
        )
        framed = np.where(inside, np.minimum(framed, distance), framed)
    return np.where(np.isfinite(framed), framed, nearest)


def noise_per_distance(heights: np.ndarray, distances: np.ndarray) -> float:
    """Standard deviation of a floor point's height per unit of its distance from the camera,
    measured on the points just below the plane (0 when too few lie there to tell)."""
    heights = np.asarray(heights, np.float64).reshape(-1)
    distances = np.maximum(np.asarray(distances, np.float64).reshape(-1), 1e-9)
    slope = heights / distances
    below = slope[(slope < 0) & (slope >= -_NOISE_SLOPE_LIMIT)]
    if len(below) < _MIN_BELOW:
        return 0.0
    # Below the plane is one half of a spread centred on it: its median |height| is the spread's MAD.
    return float(_MAD_TO_SIGMA * np.median(-below))


def _refit(floor: Floor, points: np.ndarray, sigma: np.ndarray) -> Floor:
    """The plane fitted to the points within ``SIGMAS`` of their spread, each weighted by its
    inverse variance: far points, noisier, count less (weighted least squares)."""
    near = np.abs(floor.height(points)) <= SIGMAS * sigma
    if np.count_nonzero(near) < 3:
        return floor
    weights = 1.0 / sigma[near] ** 2
    chosen = points[near]
    middle = weights @ chosen / weights.sum()
    centred = chosen - middle
    _, vectors = np.linalg.eigh((centred * weights[:, None]).T @ centred)
    normal = vectors[:, 0] if vectors[:, 0] @ floor.up >= 0 else -vectors[:, 0]
    if np.degrees(np.arccos(np.clip(normal @ floor.up, -1.0, 1.0))) > _MAX_REFIT_TILT_DEG:
        return floor  # not the voted floor fitted better, but another plane
    first, second = floor_axes(normal)
    return Floor(up=normal, offset=float(normal @ middle), first=first, second=second)


def floor_and_tolerance(
    floor: Floor,
    points: np.ndarray,
    extrinsics: np.ndarray,
    intrinsics: np.ndarray,
    sizes,
) -> tuple[Floor, np.ndarray, float]:
    """The floor refitted for noisy heights, and per point the height (scene units) within which it
    cannot be told from that floor (``SIGMAS`` standard deviations at its distance); and that
    standard deviation per unit distance.

    Heights that scatter less than ``_EXACT_SHARE`` of the cameras' height as far as the cameras
    frame them (posed RGB-D) are exact: their plane is kept and nothing is tolerated. Others are
    refitted (a plane fitted as if all heights were alike is tilted by the far, noisy ones).
    """
    points = np.asarray(points, np.float64).reshape(-1, 3)
    centres = -np.einsum("vji,vj->vi", extrinsics[:, :3, :3], extrinsics[:, :3, 3])
    camera_height = float(np.median(floor.height(centres)))

    def exact(per_distance: float, distances: np.ndarray) -> bool:
        return SIGMAS * per_distance * float(np.max(distances, initial=0.0)) <= _EXACT_SHARE * camera_height

    # a sample tells whether they scatter at all (a posed cloud has half a million points)
    sample = points
    if len(points) > _SAMPLE:
        sample = points[np.random.default_rng(0).choice(len(points), _SAMPLE, replace=False)]
    sample_distances = viewing_distance(sample, extrinsics, intrinsics, sizes)
    per_distance = noise_per_distance(floor.height(sample), sample_distances)
    if exact(per_distance, sample_distances):
        return floor, np.zeros(len(points)), per_distance
    distances = viewing_distance(points, extrinsics, intrinsics, sizes)
    per_distance = noise_per_distance(floor.height(points), distances)
    for _ in range(_REFITS):
        if exact(per_distance, distances):
            break
        floor = _refit(floor, points, np.maximum(per_distance * distances, 1e-12))
        per_distance = noise_per_distance(floor.height(points), distances)
    return floor, SIGMAS * per_distance * distances, per_distance


def noise_warnings(
    recon, goal: np.ndarray, per_distance: float, per_metre: float, clearance_m: float
) -> list[str]:
    """A sentence when, at the goal, things taller than the robot's floor clearance may pass for floor."""
    placed = recon.registered
    distance = viewing_distance(
        np.asarray(goal, np.float64).reshape(1, 3),
        recon.extrinsics[placed],
        recon.intrinsics[placed],
        recon.image_sizes[placed],
    )[0]
    hidden_m = SIGMAS * per_distance * distance / per_metre
    if hidden_m <= clearance_m:
        return []
    return [
        f"the photos' points scatter about the floor, more the farther they are from the cameras: "
        f"at the goal ({distance / per_metre:.1f} m from the nearest camera that shows it) a thing "
        f"lower than {hidden_m:.2f} m cannot be told from the floor; look again closer"
    ]


def floor_at_pixel(recon, view: int, u: float, v: float) -> tuple[np.ndarray | None, str | None]:
    """Where pixel (u, v) of a placed view meets the fitted floor, when nothing but floor is seen in
    front of that floor point around the pixel: a sparse cloud has no points on a plain floor.

    Of the points framed within ``_PIXEL_REACH`` of the image's larger side, those nearer the camera
    than the pixel's floor point must be floor within their scatter: a pixel on a wall or a box
    meets the floor behind it, and the wall's or box's own points around it are nearer.
    (world point, None) or (None, why not).
    """
    placed = recon.registered
    points = np.asarray(recon.points, np.float64).reshape(-1, 3)
    try:
        floor = estimate_floor(points, recon.extrinsics[placed])
    except ValueError as error:  # too few points to find the floor
        return None, str(error)
    floor, tolerance, _ = floor_and_tolerance(
        floor, points, recon.extrinsics[placed], recon.intrinsics[placed], recon.image_sizes[placed]
    )
    pose, intrinsic = recon.extrinsics[view], recon.intrinsics[view]
    centre = -pose[:, :3].T @ pose[:, 3]
    ray = pose[:, :3].T @ np.linalg.solve(intrinsic, [u, v, 1.0])
    along = float(ray @ floor.up)
    if along >= 0:
        return None, "the pixel looks above the floor's horizon"
    point = centre + (floor.offset - float(centre @ floor.up)) / along * ray
    depth = float((point - centre) @ pose[2, :3])
    in_camera = points @ pose[:, :3].T + pose[:, 3]
    front = np.flatnonzero(in_camera[:, 2] > 1e-9)
    pixels = in_camera[front] @ intrinsic.T
    pixels = pixels[:, :2] / pixels[:, 2:]
    reach = _PIXEL_REACH * float(max(recon.image_sizes[view]))
    near = front[np.linalg.norm(pixels - [u, v], axis=1) <= reach]
    if len(near) < _FLOOR_NEIGHBOURS:
        return None, f"fewer than {_FLOOR_NEIGHBOURS} points within {reach:.0f} px to tell if it is floor"
    band = np.maximum(tolerance[near], _FLOOR_BAND * float(floor.height(centre)[0]))
    on_floor = np.abs(floor.height(points[near])) <= band
    nearer = in_camera[near, 2] < depth
    if np.count_nonzero(nearer & ~on_floor) > (1.0 - _FLOOR_SHARE) * max(np.count_nonzero(nearer), 1):
        return None, f"something other than floor is seen in front of its floor point within {reach:.0f} px"
    return point, None
