"""Heights from a photo-only reconstruction: floor points scatter more the farther they are.

A synthetic scene-unit point cloud stands in for a sparse classical reconstruction: two cameras at
head height looking over a floor, whose points' heights carry noise that grows in proportion to
their distance from the cameras, and a box standing on that floor. The noisy far floor must not
be taken for obstacles; the box must; and exact heights (posed RGB-D) keep a low obstacle one.
"""

from __future__ import annotations

import numpy as np
import pytest

from shared.geometry.reconstruction import Reconstruction
from shared.navigation import Robot, estimate_floor, plan_route
from shared.navigation.grid import build_grid
from shared.navigation.noise import SIGMAS, floor_and_tolerance, noise_per_distance, viewing_distance

SCALE = 0.4  # scene units per metre: the reconstruction knows no metres
CAMERA_HEIGHT_M = 1.5
PITCH_DEG = 28.0
FOCAL, WIDTH, HEIGHT = 260.0, 320, 240
RELATIVE_NOISE = 0.008  # height noise (one standard deviation) per metre of distance from the cameras
CLEARANCE_M = 0.05
ROBOT = Robot(radius=0.25, floor_clearance=CLEARANCE_M, camera_height=CAMERA_HEIGHT_M)
BOX = (np.array([5.7, 0.5]), np.array([6.3, 1.1]), 0.4)  # metres: floor corners (x, y) and height
GOAL_M = np.array([7.0, -0.5])


def _cameras() -> tuple[np.ndarray, np.ndarray]:
    """Two cameras 1 m apart, looking along +x and pitched down (camera-from-world, scene units)."""
    pitch = np.radians(PITCH_DEG)
    forward = np.array([np.cos(pitch), 0.0, -np.sin(pitch)])
    right = np.array([0.0, -1.0, 0.0])
    rotation = np.stack([right, np.cross(forward, right), forward])
    poses = []
    for y in (0.0, 1.0):
        centre = np.array([0.0, y, CAMERA_HEIGHT_M]) * SCALE
        poses.append(np.hstack([rotation, (-rotation @ centre)[:, None]]))
    intrinsic = np.array([[FOCAL, 0, WIDTH / 2 - 0.5], [0, FOCAL, HEIGHT / 2 - 0.5], [0, 0, 1]])
    return np.array(poses), np.array([intrinsic, intrinsic])


def _box_surface(rng, count: int, low, high, top: float) -> np.ndarray:
    """Points on a box's four sides and its top (metres)."""
    out = []
    for _ in range(count):
        face = rng.integers(5)
        x, y, z = rng.uniform(low[0], high[0]), rng.uniform(low[1], high[1]), rng.uniform(0, top)
        if face == 0:
            x = low[0]
        elif face == 1:
            x = high[0]
        elif face == 2:
            y = low[1]
        elif face == 3:
            y = high[1]
        else:
            z = top
        out.append((x, y, z))
    return np.array(out)


def _cloud(relative_noise: float, box=BOX, seed: int = 0) -> Reconstruction:
    """The floor (x 0-8.5 m, y -2.5-2.5 m) and the box, heights noisier with distance, in scene units."""
    rng = np.random.default_rng(seed)
    floor = np.column_stack([rng.uniform(0.0, 8.5, 40_000), rng.uniform(-2.5, 2.5, 40_000), np.zeros(40_000)])
    low, high, top = box
    inside = np.all((floor[:, :2] >= low) & (floor[:, :2] <= high), axis=1)
    points = np.vstack([floor[~inside], _box_surface(rng, 6_000, low, high, top)])
    extrinsics, intrinsics = _cameras()
    centres = np.array([-pose[:, :3].T @ pose[:, 3] for pose in extrinsics]) / SCALE
    distance = np.min(np.linalg.norm(points[:, None, :] - centres[None], axis=2), axis=1)
    points[:, 2] += rng.normal(0.0, 1.0, len(points)) * relative_noise * distance
    return Reconstruction(
        points=points * SCALE,
        colors=np.full((len(points), 3), 128, np.uint8),
        extrinsics=extrinsics,
        intrinsics=intrinsics,
        image_sizes=np.array([[WIDTH, HEIGHT]] * 2),
        registered=np.ones(2, bool),
        backbone="classical",
        backbone_version="test",
    )


def _floor_point(xy_m) -> np.ndarray:
    return np.array([xy_m[0], xy_m[1], 0.0]) * SCALE


def test_the_spread_per_distance_is_measured_below_the_floor():
    recon = _cloud(RELATIVE_NOISE)
    distances = viewing_distance(recon.points, recon.extrinsics, recon.intrinsics, recon.image_sizes)
    # heights over the true floor (z = 0); distances and heights are both in scene units: their
    # ratio is the noise per metre
    measured = noise_per_distance(recon.points[:, 2], distances)
    assert measured == pytest.approx(RELATIVE_NOISE, rel=0.05)
    exact = _cloud(0.0)
    exact_distances = viewing_distance(exact.points, exact.extrinsics, exact.intrinsics, exact.image_sizes)
    assert noise_per_distance(exact.points[:, 2], exact_distances) == 0.0


def _grids(recon: Reconstruction):
    floor = estimate_floor(recon.points, recon.extrinsics)
    per_metre = floor.height(-recon.extrinsics[0, :, :3].T @ recon.extrinsics[0, :, 3])[0] / CAMERA_HEIGHT_M
    band = (CLEARANCE_M * per_metre, 0.5 * per_metre)
    floor, noise, _ = floor_and_tolerance(
        floor, recon.points, recon.extrinsics, recon.intrinsics, recon.image_sizes
    )
    plane, heights = floor.to_plane(recon.points), floor.height(recon.points)
    keep = plane[:1]
    common = (plane, heights, band, 0.05 * per_metre, 0.03 * per_metre, 3.0, keep)
    return floor, build_grid(*common), build_grid(*common, height_noise=noise)


def _cells_near_box(floor, grid, margin_m: float) -> np.ndarray:
    """(H, W) bool: cells whose centre lies within ``margin_m`` of the box's footprint."""
    low, high, _ = BOX
    rows, columns = np.indices(grid.shape)
    centres = grid.to_plane(np.stack([rows.ravel(), columns.ravel()], axis=1))
    corners = floor.to_plane(np.array([_floor_point(low), _floor_point(high)]))
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    gap = np.linalg.norm(np.maximum(np.maximum(lo - centres, centres - hi), 0.0), axis=1)
    return (gap <= margin_m * SCALE).reshape(grid.shape)


def test_the_noisy_far_floor_is_floor_and_the_box_stays_an_obstacle():
    recon = _cloud(RELATIVE_NOISE)
    floor, plain, honest = _grids(recon)
    near_box = _cells_near_box(floor, honest, margin_m=0.1)
    # Without the tolerance the far floor's noise stands above the robot's clearance here and there.
    assert np.count_nonzero(plain.occupied & ~near_box) > 100
    assert not np.any(honest.occupied & ~near_box)
    # The box's sides rise above the noise at its distance: its outline is closed.
    on_box = _cells_near_box(floor, honest, margin_m=0.0) & ~_cells_near_box(floor, honest, margin_m=-0.1)
    assert np.count_nonzero(honest.occupied & on_box) >= 0.9 * np.count_nonzero(on_box)


def test_a_far_goal_on_noisy_floor_is_planned_round_the_box_and_the_doubt_is_said():
    recon = _cloud(RELATIVE_NOISE)
    plan = plan_route(recon, 0, _floor_point(GOAL_M), robot=ROBOT)
    assert plan.reachable, plan.reason
    assert plan.units == "metres" and plan.scale_from == "camera height"
    low, high, _ = BOX
    path = plan.path_world[:, :2] / SCALE
    samples = np.concatenate([np.linspace(a, b, 50) for a, b in zip(path[:-1], path[1:], strict=True)])
    gap = np.linalg.norm(np.maximum(np.maximum(low - samples, samples - high), 0.0), axis=1)
    assert gap.min() >= ROBOT.radius
    centres = np.array([-pose[:, :3].T @ pose[:, 3] for pose in recon.extrinsics]) / SCALE
    goal_distance = np.min(np.linalg.norm(centres - [*GOAL_M, 0.0], axis=1))
    assert SIGMAS * RELATIVE_NOISE * goal_distance > CLEARANCE_M  # so the doubt at the goal is said
    assert any("cannot be told from the floor" in w for w in plan.warnings)
    into_box = plan_route(recon, 0, _floor_point((low + high) / 2), robot=ROBOT)
    assert not into_box.reachable


def test_exact_heights_keep_a_low_obstacle():
    """Posed RGB-D: nothing lies below the floor, so nothing is tolerated above the clearance."""
    low_step = (GOAL_M - 0.4, GOAL_M + 0.4, 0.1)  # 0.1 m high, above the 0.05 m clearance
    recon = _cloud(0.0, box=low_step)
    _, plain, honest = _grids(recon)
    # what scatter the fit leaves is below the floor tolerance everywhere: the grid is as without it
    assert np.array_equal(plain.occupied, honest.occupied) and np.array_equal(plain.free, honest.free)
    plan = plan_route(recon, 0, _floor_point(GOAL_M), robot=ROBOT)
    assert not plan.reachable
    assert not any("cannot be told from the floor" in w for w in plan.warnings)
