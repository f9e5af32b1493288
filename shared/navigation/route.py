"""``locate`` and ``plan_route``: a goal pixel to a world point; a start view and a goal to steps.

A plan is a list of steps ``{turn_degrees, move}``: turn in place about the floor's up axis
(``left-positive``: counter-clockwise seen from above), then drive forward ``move``. It starts on
the floor below the start view's camera, facing that camera's horizontal heading.

Distances are in metres when the reconstruction is metric. Otherwise they are scene units, and
the robot's size is turned into scene units by assuming the start camera was held at
``ASSUMED_CAMERA_HEIGHT_M`` above the floor (a warning says so).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from shared.geometry.reconstruction import Reconstruction
from shared.navigation.floor import Floor, estimate_floor
from shared.navigation.grid import Grid, build_grid, dilate
from shared.navigation.search import astar, reachable_from, shorten

TURN_CONVENTION = "left-positive"
ASSUMED_CAMERA_HEIGHT_M = 1.5
CELL_M = 0.05
SAFETY_MARGIN_M = 0.05  # added to the radius: the grid's half cell must not become a collision
GOAL_TOLERANCE_M = 0.3
_FLOOR_TOLERANCE_M = 0.03
_CLOSE_HOLES_M = 0.15
_MIN_TURN_DEG = 0.5


@dataclass(frozen=True)
class Robot:
    radius: float = 0.25  # metres
    height: float = 0.5  # top of the body above the floor, metres
    floor_clearance: float = 0.05  # bottom of the body: lower things (a rug, a cable) are driven over

    def __post_init__(self) -> None:
        if not (self.radius > 0 and self.height > self.floor_clearance >= 0):
            raise ValueError(f"robot needs radius > 0 and height > floor_clearance >= 0, got {self}")


@dataclass
class LocateResult:
    point: np.ndarray | None  # (3,) world point, None when nothing there is reconstructed
    reason: str | None = None
    source: str | None = None  # "depth" or "points"


@dataclass
class RoutePlan:
    reachable: bool
    units: str  # "metres" or "scene units"
    reason: str | None = None
    refusal: str | None = (
        None  # start_blocked, goal_in_obstacle, goal_unseen, narrow_gap, enclosed, unseen_space
    )
    steps: list[dict] = field(default_factory=list)
    sentences: list[str] = field(default_factory=list)
    path_world: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    path_start_camera: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    clearance: float | None = None  # smallest gap between the robot's disc and an obstacle
    length: float | None = None
    straight_line_distance: float | None = None
    start_world: np.ndarray | None = None  # floor point below the start camera
    goal_world: np.ndarray | None = None  # the goal projected on the floor
    up: np.ndarray | None = None
    warnings: list[str] = field(default_factory=list)
    turn_convention: str = TURN_CONVENTION
    # Metres per unit of the moves: 1 when metric, else the estimate from the assumed camera height.
    metres_per_unit: float | None = None

    def to_dict(self) -> dict:
        def listed(array):
            return None if array is None else np.round(np.asarray(array, np.float64), 4).tolist()

        return {
            "reachable": self.reachable,
            "units": self.units,
            "reason": self.reason,
            "refusal": self.refusal,
            "turn_convention": self.turn_convention,
            "steps": self.steps,
            "sentences": self.sentences,
            "path_world": listed(self.path_world),
            "path_start_camera": listed(self.path_start_camera),
            "clearance": self.clearance,
            "length": self.length,
            "straight_line_distance": self.straight_line_distance,
            "start_world": listed(self.start_world),
            "goal_world": listed(self.goal_world),
            "up": listed(self.up),
            "warnings": self.warnings,
            "metres_per_unit": self.metres_per_unit,
        }


def _view_pixel_check(recon: Reconstruction, view: int, u: float, v: float) -> None:
    if not 0 <= view < recon.num_views:
        raise ValueError(f"view {view + 1} does not exist: the reconstruction has views 1..{recon.num_views}")
    width, height = recon.image_sizes[view]
    if not (np.isfinite(u) and np.isfinite(v) and -0.5 <= u < width - 0.5 and -0.5 <= v < height - 0.5):
        raise ValueError(f"pixel ({u}, {v}) is outside view {view + 1}'s image of {width}x{height}")


def _locate_by_depth(recon: Reconstruction, view: int, u: float, v: float) -> LocateResult | None:
    depth = recon.depths[view] if recon.depths is not None else None
    if depth is None or depth.size == 0:
        return None
    width, height = recon.image_sizes[view]
    sx, sy = depth.shape[1] / width, depth.shape[0] / height
    row = min(int(round(v * sy)), depth.shape[0] - 1)
    column = min(int(round(u * sx)), depth.shape[1] - 1)
    z = float(depth[row, column])
    if not (np.isfinite(z) and z > 0):
        return LocateResult(None, f"view {view + 1} has no depth at pixel ({u:g}, {v:g})", "depth")
    intrinsic, pose = recon.intrinsics[view], recon.extrinsics[view]
    in_camera = np.array(
        [(u - intrinsic[0, 2]) / intrinsic[0, 0] * z, (v - intrinsic[1, 2]) / intrinsic[1, 1] * z, z]
    )
    return LocateResult(pose[:, :3].T @ (in_camera - pose[:, 3]), None, "depth")


def _locate_by_points(recon: Reconstruction, view: int, u: float, v: float) -> LocateResult:
    pose, intrinsic = recon.extrinsics[view], recon.intrinsics[view]
    in_camera = recon.points.astype(np.float64) @ pose[:, :3].T + pose[:, 3]
    front = in_camera[:, 2] > 1e-9
    pixels = in_camera[front] @ intrinsic.T
    pixels = pixels[:, :2] / pixels[:, 2:]
    radius = max(3.0, 0.01 * float(max(recon.image_sizes[view])))
    near = np.linalg.norm(pixels - [u, v], axis=1) <= radius
    if not near.any():
        return LocateResult(
            None,
            f"nothing is reconstructed within {radius:.0f} px of ({u:g}, {v:g}) in view {view + 1}",
            "points",
        )
    depths = in_camera[front][near, 2]
    # The nearest surface under the pixel: points behind it (seen by other views) are not what it shows.
    nearest = depths <= np.percentile(depths, 10) * 1.05
    return LocateResult(recon.points[front][near][nearest].astype(np.float64).mean(axis=0), None, "points")


def locate(recon: Reconstruction, view: int, u: float, v: float) -> LocateResult:
    """The world point seen at pixel (u, v) (column, row; pixel centres at integers) of a view.

    ``view`` is the view's index in the reconstruction (0-based); messages name it from 1, as people
    and the APIs on top (``/v1/route``, the program API) count views."""
    _view_pixel_check(recon, view, u, v)
    if not recon.registered[view]:
        return LocateResult(None, f"view {view + 1} has no pose in this reconstruction")
    by_depth = _locate_by_depth(recon, view, u, v)
    if by_depth is not None and (by_depth.point is not None or recon.backbone == "posed-rgbd"):
        return by_depth  # measured depth says what the view saw; a hole in it is nothing seen
    # A hole in an estimated depth map (a backbone's has many) is not yet nothing: the points may cover it.
    by_points = _locate_by_points(recon, view, u, v)
    if by_points.point is None and by_depth is not None:
        by_points.reason = f"{by_depth.reason}, and {by_points.reason}"
    return by_points


@dataclass
class _Setting:
    """What a plan is made on: the floor, the grid, the start pose and the scale."""

    floor: Floor
    grid: Grid
    passable: np.ndarray
    start: np.ndarray  # (2,) floor coordinates below the start camera
    heading: float  # radians in the floor frame, counter-clockwise from the first axis
    per_metre: float  # scene units per metre
    units: str
    warnings: list[str]


def _scale(recon: Reconstruction, floor: Floor, centre: np.ndarray) -> tuple[float, str, list[str]]:
    if recon.units == "metres":
        return 1.0, "metres", []
    camera_height = float(floor.height(centre)[0])
    if camera_height <= 0:
        raise ValueError("the start camera is not above the estimated floor")
    warning = (
        "the reconstruction has no metric scale: distances are in scene units, and the robot's size "
        f"was scaled assuming the start camera was {ASSUMED_CAMERA_HEIGHT_M} m above the floor"
    )
    return camera_height / ASSUMED_CAMERA_HEIGHT_M, "scene units", [warning]


def _setting(recon: Reconstruction, start_view: int, goal: np.ndarray, robot: Robot) -> _Setting:
    if not 0 <= start_view < recon.num_views:
        raise ValueError(
            f"start view {start_view + 1} does not exist: the reconstruction has views 1..{recon.num_views}"
        )
    if not recon.registered[start_view]:
        raise ValueError(f"start view {start_view + 1} has no pose in this reconstruction")
    floor = estimate_floor(recon.points, recon.extrinsics[recon.registered])
    pose = recon.extrinsics[start_view]
    centre = -pose[:, :3].T @ pose[:, 3]
    per_metre, units, warnings = _scale(recon, floor, centre)
    start = floor.to_plane(centre)[0]
    forward = floor.to_plane(pose[2, :3])[0]
    plane, heights = floor.to_plane(recon.points), floor.height(recon.points)
    band = (robot.floor_clearance * per_metre, robot.height * per_metre)
    cell = CELL_M * per_metre
    grid = build_grid(
        plane,
        heights,
        band,
        cell,
        _FLOOR_TOLERANCE_M * per_metre,
        _CLOSE_HOLES_M / CELL_M,
        np.stack([start, floor.to_plane(goal)[0]]),
    )
    # The robot stands at the start: its own footprint is free floor even if no view saw it.
    footprint = _cells_within(grid, start, (robot.radius + SAFETY_MARGIN_M) * per_metre + grid.cell)
    grid.free |= footprint & ~grid.occupied
    radius_cells = (robot.radius + SAFETY_MARGIN_M) * per_metre / grid.cell
    passable = ~dilate(~grid.free, radius_cells)
    heading = float(np.arctan2(forward[1], forward[0]))
    return _Setting(floor, grid, passable, start, heading, per_metre, units, warnings)


def _cells_within(grid: Grid, centre: np.ndarray, radius: float) -> np.ndarray:
    rows, columns = np.indices(grid.shape)
    plane = np.stack([columns, rows], axis=-1) * grid.cell + grid.origin
    return np.linalg.norm(plane - centre, axis=-1) <= radius


def _goal_cell(
    setting: _Setting, goal_plane: np.ndarray, robot: Robot
) -> tuple[tuple[int, int] | None, str | None, str | None]:
    """The cell to drive to, or (None, refusal kind, reason)."""
    grid = setting.grid
    cell = grid.to_cell(goal_plane)[0]
    if not grid.inside(cell[None])[0]:
        return None, "goal_unseen", "the goal lies outside everything the views saw"
    row, column = int(cell[0]), int(cell[1])
    if grid.occupied[row, column]:
        return None, "goal_in_obstacle", "the goal is inside an obstacle at the robot's body height"
    if not grid.free[row, column]:
        return None, "goal_unseen", "no view saw the floor at the goal"
    if setting.passable[row, column]:
        return (row, column), None, None
    near = _cells_within(grid, goal_plane, GOAL_TOLERANCE_M * setting.per_metre) & setting.passable
    if not near.any():
        return (
            None,
            "goal_too_close",
            (
                f"the goal is closer to an obstacle than the robot's radius ({robot.radius:g} m) and no "
                f"free spot within {GOAL_TOLERANCE_M} m of it fits the robot"
            ),
        )
    candidates = np.argwhere(near)
    best = candidates[np.argmin(np.linalg.norm(grid.to_plane(candidates) - goal_plane, axis=1))]
    return (int(best[0]), int(best[1])), None, None


def _distance_to(cells_plane: np.ndarray, obstacles: np.ndarray) -> np.ndarray:
    """Distance from each floor point to the nearest obstacle point (chunked brute force)."""
    if len(obstacles) == 0:
        return np.full(len(cells_plane), np.inf)
    out = np.empty(len(cells_plane))
    for start in range(0, len(cells_plane), 256):
        chunk = cells_plane[start : start + 256]
        out[start : start + 256] = np.sqrt(((chunk[:, None, :] - obstacles[None]) ** 2).sum(-1)).min(axis=1)
    return out


def _boundary(mask: np.ndarray) -> np.ndarray:
    """Set cells with an unset 4-neighbour: the ones that matter for distances."""
    inner = mask.copy()
    inner[1:-1, 1:-1] = mask[:-2, 1:-1] & mask[2:, 1:-1] & mask[1:-1, :-2] & mask[1:-1, 2:]
    return mask & ~inner


def _why_unreachable(
    setting: _Setting, start: tuple[int, int], goal: tuple[int, int], robot: Robot
) -> tuple[str, str]:
    """Refusal kind and reason when no path fits the inflated grid."""
    grid = setting.grid
    cells = astar(grid.free, start, goal)
    if cells is not None:
        # Free floor joins them, but somewhere it is narrower than the robot: say where and how wide.
        plane = grid.to_plane(np.array(cells))
        blocked = grid.to_plane(np.argwhere(_boundary(~grid.free)))
        distance = _distance_to(plane, blocked)
        narrowest = int(np.argmin(distance))
        width = (2 * distance[narrowest] - grid.cell) / setting.per_metre
        where = setting.floor.to_world(plane[narrowest])[0]
        unit = "m" if setting.units == "metres" else "scene units (scaled)"
        return "narrow_gap", (
            f"the narrowest passage on the way, near ({where[0]:.2f}, {where[1]:.2f}, {where[2]:.2f}), is "
            f"about {max(width, 0.0):.2f} {unit} wide; the robot needs {2 * robot.radius:.2f} m plus a margin"
        )
    if reachable_from(~grid.occupied, start)[goal]:
        return "unseen_space", "every way to the goal passes through floor that no view saw"
    return "enclosed", "the goal is enclosed: obstacles close every way from the start to it"


def _turn_words(turn: float) -> str:
    return f"turn {'left' if turn > 0 else 'right'} {abs(turn):.0f}°"


def _steps(corners: np.ndarray, heading: float, units: str) -> tuple[list[dict], list[str]]:
    steps, sentences = [], []
    unit = "m" if units == "metres" else "scene units"
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        offset = b - a
        move = float(np.linalg.norm(offset))
        if move <= 1e-9:
            continue
        direction = float(np.arctan2(offset[1], offset[0]))
        turn = float(np.degrees((direction - heading + np.pi) % (2 * np.pi) - np.pi))
        heading = direction
        steps.append({"turn_degrees": round(turn, 2), "move": round(move, 4)})
        go = f"go forward {move:.2f} {unit}"
        sentences.append(f"{_turn_words(turn)}, then {go}" if abs(turn) >= _MIN_TURN_DEG else go.capitalize())
    return steps, [sentence[0].upper() + sentence[1:] for sentence in sentences]


def _refusal(setting: _Setting, kind: str, reason: str, goal_plane: np.ndarray) -> RoutePlan:
    return RoutePlan(
        reachable=False,
        units=setting.units,
        reason=reason,
        refusal=kind,
        start_world=setting.floor.to_world(setting.start)[0],
        goal_world=setting.floor.to_world(goal_plane)[0],
        straight_line_distance=float(np.linalg.norm(goal_plane - setting.start)),
        up=setting.floor.up,
        warnings=setting.warnings,
        metres_per_unit=1.0 / setting.per_metre,
    )


def _clearance(setting: _Setting, corners: np.ndarray, robot: Robot) -> float:
    """Smallest distance between the robot's disc and an occupied cell along the path."""
    samples = [corners[:1]]
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        count = max(int(np.ceil(np.linalg.norm(b - a) / (0.5 * setting.grid.cell))), 1)
        samples.append(a + np.linspace(0.0, 1.0, count + 1)[1:, None] * (b - a))
    obstacles = setting.grid.to_plane(np.argwhere(_boundary(setting.grid.occupied)))
    nearest = float(_distance_to(np.concatenate(samples), obstacles).min())
    return nearest / setting.per_metre - robot.radius


def plan_route(
    recon: Reconstruction,
    start_view: int,
    goal: np.ndarray,
    robot_radius: float = 0.25,
    robot: Robot | None = None,
) -> RoutePlan:
    """A collision-free route from the floor below the start view's camera to the goal point.

    ``goal`` is a world point (on the floor or on something standing on it; its floor projection is
    what the robot drives to). ``start_view`` is an index (0-based); messages name it from 1.
    ``robot`` overrides ``robot_radius``. A goal that no route reaches
    gives ``reachable=False`` with the refusal's kind and reason. ``ValueError`` for a bad view.
    """
    robot = robot or Robot(radius=robot_radius)
    goal = np.asarray(goal, np.float64).reshape(-1)
    if goal.shape != (3,) or not np.all(np.isfinite(goal)):
        raise ValueError(f"goal must be 3 finite numbers, got {goal.tolist()}")
    setting = _setting(recon, start_view, goal, robot)
    goal_plane = setting.floor.to_plane(goal)[0]
    start_cell = tuple(int(i) for i in setting.grid.to_cell(setting.start)[0])
    if not setting.passable[start_cell]:
        return _refusal(
            setting, "start_blocked", "an obstacle is within the robot's radius of its start", goal_plane
        )
    goal_cell, kind, reason = _goal_cell(setting, goal_plane, robot)
    if goal_cell is None:
        return _refusal(setting, kind, reason, goal_plane)
    cells = astar(setting.passable, start_cell, goal_cell)
    if cells is None:
        return _refusal(setting, *_why_unreachable(setting, start_cell, goal_cell, robot), goal_plane)
    corners = np.array(shorten(setting.passable, cells))
    corners = setting.grid.to_plane(corners)
    corners[0] = setting.start  # the cell centre is up to half a cell off; the robot starts exactly here
    steps, sentences = _steps(corners, setting.heading, setting.units)
    world = setting.floor.to_world(corners)
    pose = recon.extrinsics[start_view]
    plan = _refusal(setting, "", "", goal_plane)
    plan.reachable, plan.reason, plan.refusal = True, None, None
    plan.steps, plan.sentences, plan.path_world = steps, sentences, world
    plan.path_start_camera = world @ pose[:, :3].T + pose[:, 3]
    plan.length = float(sum(step["move"] for step in steps))
    plan.clearance = _clearance(setting, corners, robot)
    return plan
