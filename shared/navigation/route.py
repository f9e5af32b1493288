"""``locate`` and ``plan_route``: a goal pixel to a world point; a start view and a goal to steps.

A plan is a list of steps ``{turn_degrees, move}``: turn in place about the floor's up axis
(``left-positive``: counter-clockwise seen from above), then drive forward ``move``. It starts on
the floor below the start view's camera, facing that camera's horizontal heading.

Distances are in metres when the reconstruction is metric, or when the robot's camera height is
given (``shared.navigation.scale``). Otherwise they are scene units, and the robot's size is turned
into scene units by assuming the start camera was held at ``ASSUMED_CAMERA_HEIGHT_M`` above the
floor (a warning says so).

The floor has three kinds of cells: seen free, seen blocked and unseen. A route may cross unseen
floor, which costs ``unseen_cost`` times as much per metre as seen floor, so it does so only where
it must or where that saves a lot; each step says how much of its move is unseen, and a refusal
means that *seen* obstacles (or the edge of the map) close every way.

Unseen floor comes in two grades. Floor some view looked over (a line of sight passed above it)
is crossed freely at ``unseen_cost``. Space no line of sight reached at all (behind a wall's edge,
a doorway no view looked through) is crossed only when no route exists without it, at
``UNLOOKED_COST_FACTOR`` times that cost, never across the line of a seen wall that runs into it
(``walls.continued_walls``) nor through the ``SHADOW_M`` behind a seen face at body height (the
unseen part of the thing seen there, ``shadow.shadows``), and the plan warns that a wall or
furniture may stand there. When even that finds no way and the refusal is ``unseen_space`` (a
doorway there, if any, no photo shows), the plan says where to take the next photo
(``look_next``, ``explore.next_look``) rather than guess which stretch of an unseen wall is open.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from shared.geometry.reconstruction import Reconstruction
from shared.navigation.explore import next_look, seen_closed
from shared.navigation.floor import Floor, estimate_floor
from shared.navigation.grid import Grid, build_grid, dilate
from shared.navigation.noise import floor_and_tolerance, floor_at_pixel, noise_warnings
from shared.navigation.passage import looked_through, narrowest_passage
from shared.navigation.scale import ASSUMED_CAMERA_HEIGHT_M, Scale, plan_scale  # noqa: F401 (re-exported)
from shared.navigation.search import astar, reachable_from, shorten
from shared.navigation.shadow import shadows
from shared.navigation.sight import looked_into
from shared.navigation.steps import steps_and_sentences
from shared.navigation.walls import continued_walls, wall_cells

TURN_CONVENTION = "left-positive"
DEFAULT_UNSEEN_COST = 1.5  # a metre over unseen floor costs as much as this many over seen floor
CELL_M = 0.05
# added to the radius: the robot and a seen obstacle may each lie half a cell's diagonal (3.5 cm) off
# their cells (with 5 cm, tuning routes grazed door jambs by 3-5 mm)
SAFETY_MARGIN_M = 0.07
GOAL_TOLERANCE_M = 0.3
_FLOOR_TOLERANCE_M = 0.03
_CLOSE_HOLES_M = 0.15
WALL_HEIGHT_M = 0.8  # surfaces seen this high are walls or tall furniture, never driven past under
UNLOOKED_COST_FACTOR = 2.0  # space no view looked into costs this many times unseen floor
# Behind a seen face at body height, unlooked space this deep is taken as the object's unseen body
# (furniture is 0.4-0.9 m deep; 0.4 left two tuning routes through the hidden half of a box).
SHADOW_M = 0.7
WALL_THICKNESS_M = 0.2  # a wall's end face lies within this of its face's line


@dataclass(frozen=True)
class Robot:
    radius: float = 0.25  # metres
    height: float = 0.5  # top of the body above the floor, metres
    floor_clearance: float = 0.05  # bottom of the body: lower things (a rug, a cable) are driven over
    camera_height: float | None = None  # metres above the floor: scales a scene-unit reconstruction

    def __post_init__(self) -> None:
        if not (self.radius > 0 and self.height > self.floor_clearance >= 0):
            raise ValueError(f"robot needs radius > 0 and height > floor_clearance >= 0, got {self}")
        if self.camera_height is not None and not (
            np.isfinite(self.camera_height) and self.camera_height > 0
        ):
            raise ValueError(
                f"the camera height must be a positive number of metres, got {self.camera_height}"
            )


@dataclass
class LocateResult:
    point: np.ndarray | None  # (3,) world point, None when nothing there is reconstructed
    reason: str | None = None
    source: str | None = None  # "depth", "points" or "floor" (the pixel's ray met the fitted floor)


@dataclass
class RoutePlan:
    reachable: bool
    units: str  # "metres" or "scene units"
    reason: str | None = None
    # start_blocked, goal_in_obstacle, goal_unseen, goal_too_close, narrow_gap, enclosed, unseen_space
    refusal: str | None = None
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
    # Metres per unit of the moves: 1 when they are metres, else the estimate from the assumed height.
    metres_per_unit: float | None = None
    scale_from: str | None = None  # "metric reconstruction", "camera height", "assumed camera height"
    floor_residual_m: float | None = None  # RMS of the floor points about the fitted plane, start view
    scale_check: float | None = None  # metric reconstruction and a camera height: their heights' ratio
    unseen_m: float | None = None  # of the length, this much crosses floor no view saw
    # Each {"step": 1-based, "start_world", "end_world", "length"}: a run of a move over unseen floor.
    unseen_stretches: list[dict] = field(default_factory=list)
    narrowest_passage_m: float | None = None  # a narrow_gap refusal: the passage's measured width
    # An unseen_space or goal_unseen refusal: where to take the next photo ({stand_world, face_world,
    # steps, sentences}; ``explore.next_look``), None when even unlooked space gives no way.
    look_next: dict | None = None

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
            "scale_from": self.scale_from,
            "floor_residual_m": self.floor_residual_m,
            "scale_check": self.scale_check,
            "unseen_m": self.unseen_m,
            "unseen_stretches": self.unseen_stretches,
            "narrowest_passage_m": self.narrowest_passage_m,
            "look_next": self.look_next,
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
    if by_points.point is None:
        # a plain floor has no points of its own: the pixel's ray meets the floor between them
        on_floor, why_not = floor_at_pixel(recon, view, u, v)
        if on_floor is not None:
            return LocateResult(on_floor, None, "floor")
        by_points.reason = f"{by_points.reason} (nor is it on the floor: {why_not})"
    if by_points.point is None and by_depth is not None:
        by_points.reason = f"{by_depth.reason}, and {by_points.reason}"
    return by_points


@dataclass
class _Setting:
    """What a plan is made on: the floor, the grid, the start pose and the scale."""

    floor: Floor
    grid: Grid
    passable: np.ndarray  # the robot's centre keeps its radius (and a margin) from seen obstacles
    cost: np.ndarray  # per unit length: 1 on seen floor, ``unseen_cost`` on unseen floor
    start: np.ndarray  # (2,) floor coordinates below the start camera
    heading: float  # radians in the floor frame, counter-clockwise from the first axis
    scale: Scale
    # What closes the way once unlooked space is opened: seen obstacles, seen walls continued, the edge.
    closed_with_unlooked_open: np.ndarray | None = None
    # of those, the unseen part presumed behind seen faces (``shadow.shadows``)
    shadows: np.ndarray | None = None

    @property
    def per_metre(self) -> float:
        return self.scale.per_metre

    @property
    def per_output(self) -> float:
        """Scene units per unit of the moves (per metre when they are metres)."""
        return self.scale.per_metre if self.scale.units == "metres" else 1.0

    def is_unseen(self, plane: np.ndarray) -> np.ndarray:
        return self._flags(self.grid.unseen, plane)

    def is_unlooked(self, plane: np.ndarray) -> np.ndarray:
        return self._flags(self.grid.hidden, plane)

    def _flags(self, mask: np.ndarray, plane: np.ndarray) -> np.ndarray:
        cells = self.grid.to_cell(plane)
        inside = self.grid.inside(cells)
        out = np.ones(len(cells), bool)
        out[inside] = mask[cells[inside, 0], cells[inside, 1]]
        return out


def _setting(
    recon: Reconstruction, start_view: int, goal: np.ndarray, robot: Robot, unseen_cost: float
) -> _Setting:
    if not 0 <= start_view < recon.num_views:
        raise ValueError(
            f"start view {start_view + 1} does not exist: the reconstruction has views 1..{recon.num_views}"
        )
    if not recon.registered[start_view]:
        raise ValueError(f"start view {start_view + 1} has no pose in this reconstruction")
    placed = recon.registered
    floor = estimate_floor(recon.points, recon.extrinsics[placed])
    # a photo-only cloud's heights scatter more the farther they are: the floor is refitted for that,
    # and a point within its scatter is not an obstacle (``noise``)
    floor, noise, per_distance = floor_and_tolerance(
        floor, recon.points, recon.extrinsics[placed], recon.intrinsics[placed], recon.image_sizes[placed]
    )
    pose = recon.extrinsics[start_view]
    centre = -pose[:, :3].T @ pose[:, 3]
    scale = plan_scale(recon.units == "metres", floor, recon.points, centre, robot.camera_height)
    scale.warnings[:0] = _placement_warnings(recon)
    per_metre = scale.per_metre
    start = floor.to_plane(centre)[0]
    forward = floor.to_plane(pose[2, :3])[0]
    plane, heights = floor.to_plane(recon.points), floor.height(recon.points)
    band = (robot.floor_clearance * per_metre, robot.height * per_metre)
    # The map reaches at least a body (and a margin) around the start and the goal.
    reach = (robot.radius + 2 * SAFETY_MARGIN_M) * per_metre + 2 * CELL_M * per_metre
    ends = np.stack([start, floor.to_plane(goal)[0]])
    keep = (ends[:, None, :] + reach * np.array([[0, 0], [1, 1], [-1, -1]])[None]).reshape(-1, 2)
    grid = build_grid(
        plane,
        heights,
        band,
        CELL_M * per_metre,
        _FLOOR_TOLERANCE_M * per_metre,
        _CLOSE_HOLES_M / CELL_M,
        keep,
        tall_height=WALL_HEIGHT_M * per_metre,
        height_noise=noise,
    )
    scale.warnings.extend(noise_warnings(recon, goal, per_distance, per_metre, robot.floor_clearance))
    # The robot's own footprint stays unseen floor when no view saw it: a plan that starts over it
    # says so (the robot stands there, but nothing in the photos shows that floor).
    grid.looked = looked_into(recon, floor, grid)
    if grid.looked is not None:  # the robot is there, and turns to look: twice its body around it
        grid.looked |= _cells_within(
            grid, start, 2 * (robot.radius + SAFETY_MARGIN_M) * per_metre + grid.cell
        )
    passable = ~dilate(grid.blocked, (robot.radius + SAFETY_MARGIN_M) * per_metre / grid.cell)
    cost = np.where(grid.unseen, float(unseen_cost), 1.0)
    heading = float(np.arctan2(forward[1], forward[0]))
    return _Setting(floor, grid, passable, cost, start, heading, scale)


def _placement_warnings(recon: Reconstruction) -> list[str]:
    """Which views the backbone did not place and why, when it placed fewer than half of them."""
    placed = int(np.count_nonzero(recon.registered))
    if placed * 2 >= recon.num_views:
        return []
    confidence = recon.view_confidence or [None] * recon.num_views
    missing = [
        f"view {index + 1} ({getattr(confidence[index], 'unregistered_reason', None) or 'not placed'})"
        for index in np.flatnonzero(~np.asarray(recon.registered))
    ]
    return [
        f"the backbone placed only {placed} of {recon.num_views} views (numbered from 1); not placed: "
        + "; ".join(missing)
        + ". The map holds only what the placed views saw: add photos that overlap those views"
    ]


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
    if grid.hidden[row, column]:
        return None, "goal_unseen", "no view looked at the goal's floor, nor over it"
    if setting.passable[row, column]:
        return (row, column), None, None
    near = _cells_within(grid, goal_plane, GOAL_TOLERANCE_M * setting.per_metre) & setting.passable
    if not near.any():
        return (
            None,
            "goal_too_close",
            (
                f"the goal is closer to a seen obstacle than the robot's radius ({robot.radius:g} m) and "
                f"no spot within {GOAL_TOLERANCE_M} m of it fits the robot"
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


def _joined_through_hidden(grid: Grid, start: tuple[int, int], goal: tuple[int, int]) -> bool:
    """Whether start and goal would be joined if the cells no view looked into were open."""
    open_ = ~(grid.occupied | (grid.blocked & ~grid.hidden & ~grid.occupied))
    return bool(reachable_from(open_, start)[goal])


def _fits(closed: np.ndarray, start: tuple[int, int], goal: tuple[int, int], radius_cells: float) -> bool:
    """Whether the robot (``radius_cells``) gets from start to goal around ``closed``."""
    passable = ~dilate(closed, radius_cells)
    return bool(passable[start] and passable[goal] and reachable_from(passable, start)[goal])


def _limits(
    setting: _Setting,
    closed: np.ndarray,
    passage,
    start: tuple[int, int],
    goal: tuple[int, int],
    radius_cells: float,
) -> bool:
    """Whether the passage is what keeps the robot out: with it widened (what stands within the
    robot's width of it cleared) the robot gets through; else something else closes the way too."""
    grid = setting.grid
    widened = closed & ~_cells_within(grid, passage.where, 2 * radius_cells * grid.cell)
    return _fits(widened, start, goal, radius_cells)


def _why_unreachable(
    setting: _Setting, start: tuple[int, int], goal: tuple[int, int], robot: Robot
) -> tuple[str, str, float | None]:
    """Refusal kind, reason and the passage's width (metres by the plan's scale) when no path fits."""
    radius_cells = (robot.radius + SAFETY_MARGIN_M) * setting.per_metre / setting.grid.cell
    passage = narrowest_passage(setting.grid, start, goal, radius_cells)
    # A passage with no seen points on a side is bounded by where no view looked: no width to tell.
    off_the_map = passage is not None and passage.sides is None
    closed = setting.closed_with_unlooked_open
    if (off_the_map or passage is None) and closed is not None:
        # Unlooked space was opened and the way still fails. A refusal tells what was seen: the
        # seen obstacles and the seen walls' lines, without the unseen part presumed behind faces.
        seen = closed & ~setting.shadows
        if not _fits(seen, start, goal, radius_cells):
            # they close it (a narrow doorway reached only across unlooked floor): measured the same way
            opened = narrowest_passage(setting.grid, start, goal, radius_cells, blocked=seen)
            if (
                opened is not None
                and opened.sides is not None
                and _limits(setting, seen, opened, start, goal, radius_cells)
            ):
                passage, off_the_map = opened, False
        else:  # only the presumed unseen parts of seen things close it (a pen's side no view saw)
            return (
                "enclosed",
                "the goal is enclosed: seen obstacles close every way from the start to it, some of them "
                "where they go on behind their seen faces into space no view looked into (taken as the "
                "unseen part of what was seen there); add a photo of that side to be sure",
                None,
            )
    # a gap between seen points that no view looked into is unknown, not a measured slot
    off_the_map = off_the_map or (passage is not None and not looked_through(setting.grid, passage))
    if off_the_map or (passage is None and _joined_through_hidden(setting.grid, start, goal)):
        return (
            "unseen_space",
            "every way to the goal passes where no view looked (not even over the floor), and across "
            "the line of a wall seen running into that space: a doorway there, if any, no photo shows; "
            "add a photo of the way between",
            None,
        )
    if passage is None:
        return (
            "enclosed",
            "the goal is enclosed: seen obstacles (or the edge of what the views cover) close every way "
            "from the start to it",
            None,
        )
    width = passage.width / setting.per_metre
    where = setting.floor.to_world(passage.where)[0]
    unit = "m" if setting.scale.units == "metres" else "m (by the assumed camera height)"
    return (
        "narrow_gap",
        f"the narrowest passage on the way, near ({where[0]:.2f}, {where[1]:.2f}, {where[2]:.2f}), is "
        f"about {width:.2f} {unit} wide between the seen obstacles on both sides; the robot needs "
        f"{2 * robot.radius:.2f} m plus a {2 * SAFETY_MARGIN_M:.2f} m margin",
        width,
    )


def _refusal(setting: _Setting, kind: str, reason: str, goal_plane: np.ndarray) -> RoutePlan:
    scale = setting.scale
    return RoutePlan(
        reachable=False,
        units=scale.units,
        reason=reason,
        refusal=kind,
        start_world=setting.floor.to_world(setting.start)[0],
        goal_world=setting.floor.to_world(goal_plane)[0],
        straight_line_distance=float(np.linalg.norm(goal_plane - setting.start)) / setting.per_output,
        up=setting.floor.up,
        warnings=list(scale.warnings),
        metres_per_unit=1.0 / setting.per_metre if scale.units == "scene units" else 1.0,
        scale_from=scale.scale_from,
        floor_residual_m=None if scale.floor_residual_m is None else round(scale.floor_residual_m, 4),
        scale_check=None if scale.check is None else round(scale.check, 4),
    )


def _closed_by_what_was_seen(
    setting: _Setting, start: tuple[int, int], goal: tuple[int, int], robot: Robot, goal_plane: np.ndarray
) -> RoutePlan | None:
    """A ``narrow_gap`` refusal when, with every unlooked cell open, a passage between seen points is
    what keeps the robot out (a doorway whose jambs a photo shows, though no view looked between
    them); None when no such passage is found."""
    radius_cells = (robot.radius + SAFETY_MARGIN_M) * setting.per_metre / setting.grid.cell
    closed = seen_closed(setting.grid, setting.shadows)
    passage = narrowest_passage(setting.grid, start, goal, radius_cells, blocked=closed)
    if (
        passage is None
        or passage.sides is None
        or not _limits(setting, closed, passage, start, goal, radius_cells)
    ):
        return None
    width = passage.width / setting.per_metre
    where = setting.floor.to_world(passage.where)[0]
    unit = "m" if setting.scale.units == "metres" else "m (by the assumed camera height)"
    plan = _refusal(
        setting,
        "narrow_gap",
        f"the narrowest passage on the way, near ({where[0]:.2f}, {where[1]:.2f}, {where[2]:.2f}), is "
        f"about {width:.2f} {unit} wide between the seen obstacles on both sides (no view looked between "
        f"them, and every other way is closed by what was seen); the robot needs {2 * robot.radius:.2f} m "
        f"plus a {2 * SAFETY_MARGIN_M:.2f} m margin",
        goal_plane,
    )
    plan.narrowest_passage_m = round(width, 3)
    return plan


def _look_next(
    setting: _Setting,
    driveable: np.ndarray,
    cost: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    robot: Robot,
) -> dict | None:
    """Where the robot takes its next photo to find the way no photo shows (``explore.next_look``)."""
    look = next_look(
        setting.grid,
        setting.shadows,
        driveable,
        cost,
        start,
        goal,
        setting.start,
        setting.heading,
        (robot.radius + SAFETY_MARGIN_M) * setting.per_metre / setting.grid.cell,
        setting.per_metre,
        setting.per_output,
        setting.scale.units,
    )
    return None if look is None else look.to_dict(setting.floor)


def _clearance(setting: _Setting, corners: np.ndarray, robot: Robot) -> float:
    """Smallest distance between the robot's disc and an occupied cell along the path."""
    samples = [corners[:1]]
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        count = max(int(np.ceil(np.linalg.norm(b - a) / (0.5 * setting.grid.cell))), 1)
        samples.append(a + np.linspace(0.0, 1.0, count + 1)[1:, None] * (b - a))
    obstacles = setting.grid.to_plane(np.argwhere(_boundary(setting.grid.occupied)))
    nearest = float(_distance_to(np.concatenate(samples), obstacles).min())
    return nearest / setting.per_metre - robot.radius


def _describe(plan: RoutePlan, setting: _Setting, corners: np.ndarray, pose: np.ndarray) -> None:
    """Fill a reachable plan's steps, sentences, path and unseen stretches from its corners."""
    steps, sentences, stretches = steps_and_sentences(
        corners,
        setting.heading,
        setting.scale.units,
        setting.per_output,
        setting.is_unseen,
        0.5 * setting.grid.cell,
    )
    world = setting.floor.to_world(corners)
    plan.steps, plan.sentences, plan.path_world = steps, sentences, world
    plan.path_start_camera = world @ pose[:, :3].T + pose[:, 3]
    plan.length = float(sum(step["move"] for step in steps))
    plan.unseen_m = round(float(sum(step["unseen_m"] for step in steps)), 4)
    plan.unseen_stretches = [
        {
            "step": stretch.step,
            "start_world": np.round(setting.floor.to_world(stretch.start_plane)[0], 4).tolist(),
            "end_world": np.round(setting.floor.to_world(stretch.end_plane)[0], 4).tolist(),
            "length": round(float(stretch.end - stretch.start), 4),
        }
        for stretch in stretches
    ]
    if plan.unseen_m > 0:
        unit = "m" if setting.scale.units == "metres" else "scene units"
        plan.warnings.append(
            f"{plan.unseen_m:.2f} {unit} of the route cross floor that no view saw (assumed free): "
            "drive those stretches slowly and look again"
        )
    unlooked = _unlooked_length(setting, corners) / setting.per_output
    if unlooked >= setting.grid.cell / setting.per_output:
        unit = "m" if setting.scale.units == "metres" else "scene units"
        plan.warnings.append(
            f"{unlooked:.2f} {unit} of it cross space that no view looked into at all (no other way was "
            "seen): a wall or furniture may stand there; stop and look before driving on"
        )


def _open_unlooked_space(setting: _Setting, robot: Robot, unseen_cost: float, recon: Reconstruction) -> None:
    """Let the search cross space no view looked into, except on the lines of seen walls and
    behind seen faces (the unseen body of what was seen there)."""
    grid = setting.grid
    per_metre = setting.per_metre
    tall = grid.tall if grid.tall is not None else grid.occupied
    walls = continued_walls(grid, tall, per_metre, 2 * robot.radius * per_metre)
    closed = grid.occupied | walls
    band = (robot.floor_clearance * per_metre, robot.height * per_metre)
    # a wall casts none: a ray grazing its face or its end beside a doorway would carry it into the
    # doorway (the end face is a wall's thickness off the line the wall's cells lie on)
    # (a wall's last metres may be seen only low: its straight run is sought among all that stands)
    wall_faces = dilate(
        wall_cells(grid, tall | grid.occupied, per_metre), WALL_THICKNESS_M * per_metre / grid.cell
    )
    behind = shadows(recon, setting.floor, grid, band, SHADOW_M * per_metre, wall_faces)
    closed |= behind
    closed[[0, -1], :] = True
    closed[:, [0, -1]] = True
    setting.closed_with_unlooked_open = closed
    setting.shadows = behind
    setting.passable = ~dilate(closed, (robot.radius + SAFETY_MARGIN_M) * setting.per_metre / grid.cell)
    setting.cost = np.where(grid.hidden, UNLOOKED_COST_FACTOR * float(unseen_cost), setting.cost)


def _unlooked_length(setting: _Setting, corners: np.ndarray) -> float:
    """Scene units of the path over space no view looked into (sampled every half cell)."""
    spacing = 0.5 * setting.grid.cell
    total = 0.0
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        count = max(int(np.ceil(np.linalg.norm(b - a) / spacing)), 1)
        samples = a + (np.arange(count) + 0.5)[:, None] / count * (b - a)
        total += float(np.count_nonzero(setting.is_unlooked(samples))) * np.linalg.norm(b - a) / count
    return total


def plan_route(
    recon: Reconstruction,
    start_view: int,
    goal: np.ndarray,
    robot_radius: float = 0.25,
    robot: Robot | None = None,
    unseen_cost: float = DEFAULT_UNSEEN_COST,
) -> RoutePlan:
    """A route from the floor below the start view's camera to the goal, clear of seen obstacles.

    ``goal`` is a world point (on the floor or on something standing on it; its floor projection is
    what the robot drives to). ``start_view`` is an index (0-based); messages name it from 1.
    ``robot`` overrides ``robot_radius``. Unseen floor may be crossed at ``unseen_cost`` (>= 1) per
    unit length; the plan says where. A goal that no route reaches gives ``reachable=False`` with the
    refusal's kind and reason. ``ValueError`` for a bad view.
    """
    robot = robot or Robot(radius=robot_radius)
    goal = np.asarray(goal, np.float64).reshape(-1)
    if goal.shape != (3,) or not np.all(np.isfinite(goal)):
        raise ValueError(f"goal must be 3 finite numbers, got {goal.tolist()}")
    if not (np.isfinite(unseen_cost) and unseen_cost >= 1.0):
        raise ValueError(f"unseen_cost must be at least 1 (seen floor costs 1), got {unseen_cost}")
    setting = _setting(recon, start_view, goal, robot, unseen_cost)
    goal_plane = setting.floor.to_plane(goal)[0]
    start_cell = tuple(int(i) for i in setting.grid.to_cell(setting.start)[0])
    if not setting.passable[start_cell]:
        return _refusal(
            setting, "start_blocked", "a seen obstacle is within the robot's radius of its start", goal_plane
        )
    goal_cell, kind, reason = _goal_cell(setting, goal_plane, robot)
    if goal_cell is None:
        plan = _refusal(setting, kind, reason, goal_plane)
        at_goal = tuple(int(i) for i in setting.grid.to_cell(goal_plane)[0])
        if kind == "goal_unseen" and setting.grid.inside(np.array([at_goal]))[0]:  # on the map, unlooked
            plan.look_next = _look_next(setting, setting.passable, setting.cost, start_cell, at_goal, robot)
        return plan
    driveable, seen_cost = setting.passable, setting.cost
    cells = astar(setting.passable, start_cell, goal_cell, setting.cost)
    if cells is None and setting.grid.hidden.any():
        _open_unlooked_space(setting, robot, unseen_cost, recon)
        cells = astar(setting.passable, start_cell, goal_cell, setting.cost)
    if cells is None:
        kind, reason, width = _why_unreachable(setting, start_cell, goal_cell, robot)
        plan = _refusal(setting, kind, reason, goal_plane)
        plan.narrowest_passage_m = None if width is None else round(width, 3)
        if kind == "unseen_space":
            plan.look_next = _look_next(setting, driveable, seen_cost, start_cell, goal_cell, robot)
            if plan.look_next is None:  # seen things close every way even with all unlooked space open
                plan = _closed_by_what_was_seen(setting, start_cell, goal_cell, robot, goal_plane) or plan
        return plan
    corners = setting.grid.to_plane(np.array(shorten(setting.passable, cells, setting.cost)))
    corners[0] = setting.start  # the cell centre is up to half a cell off; the robot starts exactly here
    plan = _refusal(setting, "", "", goal_plane)
    plan.reachable, plan.reason, plan.refusal = True, None, None
    _describe(plan, setting, corners, recon.extrinsics[start_view])
    plan.clearance = _clearance(setting, corners, robot)
    return plan
