"""Heights from a photo-only reconstruction: floor points scatter more the farther they are.

A synthetic scene-unit point cloud stands in for a sparse classical reconstruction: two cameras at
head height looking over a floor, whose points' heights carry noise that grows in proportion to
their distance from the cameras, and a box standing on that floor. The noisy far floor must not
be taken for obstacles; the box must; and exact heights (posed RGB-D) keep a low obstacle one.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from shared.geometry.reconstruction import Reconstruction
from shared.navigation import Robot, estimate_floor, locate, plan_route
from shared.navigation.grid import build_grid
from shared.navigation.noise import SIGMAS, floor_and_tolerance, noise_per_distance, viewing_distance
from shared.navigation.sight import looked_into

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


def _pixel(recon: Reconstruction, view: int, world_m) -> tuple[float, float]:
    pose, intrinsic = recon.extrinsics[view], recon.intrinsics[view]
    projected = intrinsic @ (pose[:, :3] @ (np.asarray(world_m, float) * SCALE) + pose[:, 3])
    return float(projected[0] / projected[2]), float(projected[1] / projected[2])


def _without(recon: Reconstruction, centre_m, radius_m: float) -> Reconstruction:
    """The same cloud with no point within ``radius_m`` of a world point: a plain patch."""
    keep = np.linalg.norm(recon.points / SCALE - np.asarray(centre_m), axis=1) > radius_m
    return dataclasses.replace(recon, points=recon.points[keep], colors=recon.colors[keep])


def test_a_goal_pixel_on_plain_floor_is_placed_where_its_ray_meets_the_floor():
    goal = np.array([5.0, -1.0, 0.0])  # clear of the box
    recon = _without(_cloud(RELATIVE_NOISE), goal, 1.0)
    u, v = _pixel(recon, 0, goal)
    found = locate(recon, 0, u, v)
    assert found.point is not None and found.source == "floor", found.reason
    # off by the fitted floor's error at the goal, within the heights' scatter there
    centres = np.array([-pose[:, :3].T @ pose[:, 3] for pose in recon.extrinsics]) / SCALE
    distance = np.min(np.linalg.norm(centres - goal, axis=1))
    assert np.linalg.norm(found.point / SCALE - goal) <= SIGMAS * RELATIVE_NOISE * distance / np.sin(
        np.radians(PITCH_DEG) / 2
    )
    plan = plan_route(recon, 0, found.point, robot=ROBOT)
    assert plan.reachable, plan.reason


def test_a_pixel_on_a_plain_wall_is_not_placed_on_the_floor_behind_it():
    rng = np.random.default_rng(1)
    wall = np.column_stack([np.full(8_000, 8.0), rng.uniform(-2.0, 2.0, 8_000), rng.uniform(0.0, 2.0, 8_000)])
    recon = _cloud(0.0)
    recon = dataclasses.replace(
        recon,
        points=np.vstack([recon.points, wall * SCALE]),
        colors=np.vstack([recon.colors, np.full((len(wall), 3), 128, np.uint8)]),
    )
    spot = np.array(
        [8.0, 0.0, 0.8]
    )  # on the wall, below the camera's height: its ray meets the floor behind it
    recon = _without(recon, spot, 0.3)
    found = locate(recon, 0, *_pixel(recon, 0, spot))
    assert found.point is None and "in front of its floor point" in found.reason


def test_a_small_depth_map_marks_the_floor_its_rays_cross_without_gaps():
    """An 80x60 depth map for a 320x240 photo: rays at each of its pixels are 4 photo pixels apart."""
    recon = _cloud(0.0)
    pose, intrinsic = recon.extrinsics[0], recon.intrinsics[0]
    rows, columns = np.mgrid[0:60, 0:80]
    u, v = (columns + 0.5) * 4 - 0.5, (rows + 0.5) * 4 - 0.5
    rays = np.stack([(u - intrinsic[0, 2]) / FOCAL, (v - intrinsic[1, 2]) / FOCAL, np.ones_like(u)], axis=-1)
    world_rays = rays @ pose[:, :3]
    centre = -pose[:, :3].T @ pose[:, 3]
    along = -centre[2] / np.minimum(world_rays[..., 2], -1e-9)  # to the floor z = 0
    depth = np.where(world_rays[..., 2] < 0, along, 0.0).astype(np.float32)
    depth[depth * np.linalg.norm(rays, axis=-1) > 8.0 * SCALE] = 0.0  # nothing seen beyond 8 m
    recon = dataclasses.replace(recon, depths=[depth, np.zeros((0, 0), np.float32)])
    floor = estimate_floor(recon.points, recon.extrinsics)
    grid = build_grid(
        floor.to_plane(recon.points),
        floor.height(recon.points),
        (0.02, 0.2),
        0.05 * SCALE,
        0.01,
        3.0,
        floor.to_plane(recon.points[:1]),
    )
    looked = looked_into(recon, floor, grid)
    # every cell whose centre the view frames on the floor, from 1.5 m to where rays 4 photo pixels
    # apart are a cell apart, lies under one of its rays
    farthest = 0.05 * FOCAL / 4
    cells = np.argwhere(np.ones(grid.shape, bool))
    world = floor.to_world(grid.to_plane(cells))
    in_camera = world @ pose[:, :3].T + pose[:, 3]
    pixels = in_camera @ intrinsic.T
    pixels = pixels[:, :2] / pixels[:, 2:]
    reach = np.linalg.norm(world[:, :2] - centre[:2], axis=1) / SCALE
    framed = (
        (in_camera[:, 2] > 0)
        & np.all(pixels >= 8, axis=1)
        & (pixels[:, 0] < WIDTH - 8)
        & (pixels[:, 1] < HEIGHT - 8)
        & (reach >= 1.5)
        & (reach <= farthest)
    )
    assert framed.sum() > 200
    assert looked[cells[framed, 0], cells[framed, 1]].all()


@pytest.mark.parametrize("tilt_deg", [1.0, 10.0])
def test_a_refit_follows_a_slightly_tilted_floor_but_not_another_plane(tilt_deg):
    """The weighted refit refines the voted floor; a plane further off than its limit is not it."""
    from shared.navigation.floor import Floor, floor_axes
    from shared.navigation.noise import _MAX_REFIT_TILT_DEG, _refit

    rng = np.random.default_rng(3)
    xy = rng.uniform(-3.0, 3.0, (5_000, 2))
    slope = np.tan(np.radians(tilt_deg))
    points = np.column_stack([xy, slope * xy[:, 0]])
    up = np.array([0.0, 0.0, 1.0])
    voted = Floor(up, 0.0, *floor_axes(up))
    sigma = np.full(len(points), 1.0)  # every point within the band: only the tilt limit decides
    refitted = _refit(voted, points, sigma)
    truth = np.array([-slope, 0.0, 1.0]) / np.hypot(slope, 1.0)
    if tilt_deg <= _MAX_REFIT_TILT_DEG:
        assert refitted.up @ truth == pytest.approx(1.0, abs=1e-9)
    else:
        assert refitted is voted
