"""Two rooms joined by a doorway, with furniture and posed RGB-D views: the route benchmark's scenes.

Like ``scene.py``: z is up, the floor is z = 0, cameras are OpenCV camera-from-world. The lab is
about 50 m² (two rooms side by side along x, a wall with one doorway between them), seen by 5-7
views at head height. The robot starts below the start view's camera in room A; the goal is a
floor point in room B.

Kinds:
- ``reachable``: a doorway wide enough and a goal in the open (checked on the true geometry);
- ``narrow_door``: the doorway is narrower than the robot;
- ``ring``: the goal is inside a closed pen of low partitions.

``varied=True`` draws the capture the way real ones vary (the route benchmark's scenes): 3-7 views,
one camera height per scene in 1.0-1.8 m, furniture allowed near the doorway, and one of four
doorway ``coverage`` levels (``COVERAGES``, drawn evenly):
- ``full``: views look through the doorway from both rooms;
- ``partial``: from room A only, the doorway off-centre;
- ``doorway``: the doorway is in a photo but the floor past it is in none: a room A view stands
  close to the dividing wall and looks along it, so both jambs are framed while every ray into the
  gap meets the far jamb's end face; room B's view of the goal is placed so that the floor within
  1.2 m past the doorway (a metre wider than it each side) is out of its frame, and no other view
  frames that floor (the start view faces away from the wall);
- ``none``: no photo shows the doorway: room A's views look at the dividing wall beside it, not
  through it; room B's view stands near the far end of the dividing wall.
The default is the fixed capture (5-7 views at 1.5 m) the tests were written on.

Besides the rendering mesh, every scene keeps its *solids*: the convex parts (wall slabs,
furniture parts, partitions) as vertex sets, so the true footprint at the robot's body height is
exact polygons (``footprints``), and ``disc_collides`` / ``true_shortest`` work on those.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.navigation.search import astar, shorten
from shared.synthetic.render import RenderedView, default_intrinsic, look_at, render_view
from shared.synthetic.scene import (
    CATALOGUE,
    ROOM_OBJECT_ID,
    SceneObject,
    SyntheticScene,
    _box,
    _Builder,
    _yaw_matrix,
)

KINDS = ("reachable", "narrow_door", "ring")
COVERAGES = ("full", "partial", "doorway", "none")  # the varied capture's doorway coverage, drawn evenly
EYE_HEIGHT = 1.5
WALL = 0.12  # thickness of every wall slab
_PITCH_DOWN_DEG = 28.0  # views look down so the floor in front of them is seen
_FOV_DEG = 75.0
_TRUTH_CELL = 0.025


@dataclass(eq=False)
class TwoRoomScene:
    scene: SyntheticScene  # the mesh to render (objects, materials)
    kind: str
    solids: list[np.ndarray]  # convex parts as (K, 3) vertex sets
    extrinsics: np.ndarray  # (V, 3, 4) camera-from-world; view 0 is the start view
    intrinsic: np.ndarray  # (3, 3), the same for every view
    size: tuple[int, int]  # (width, height) of the views
    goal: np.ndarray  # (3,) floor point in room B
    door: tuple[float, float]  # (y low, y high) of the doorway in the dividing wall
    divider_x: float
    goal_view: int = 3  # the view that looks at the goal
    camera_height: float = EYE_HEIGHT  # the start view's camera above the floor, metres
    coverage: str = "fixed"  # the capture's doorway coverage: fixed or one of COVERAGES

    def start_floor(self) -> np.ndarray:
        pose = self.extrinsics[0]
        centre = -pose[:, :3].T @ pose[:, 3]
        return np.array([centre[0], centre[1], 0.0])

    def render(self) -> list[RenderedView]:
        width, height = self.size
        return [render_view(self.scene, pose, self.intrinsic, width, height) for pose in self.extrinsics]


def footprints(solids: list[np.ndarray], band: tuple[float, float]) -> list[np.ndarray]:
    """Convex floor polygons (counter-clockwise) of the solids that reach into the height band."""
    polygons = []
    for vertices in solids:
        if vertices[:, 2].max() < band[0] or vertices[:, 2].min() > band[1]:
            continue
        polygons.append(_convex_hull(_band_slice(vertices, band)))
    return polygons


def _band_slice(vertices: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """Floor points whose hull is the convex solid's slice by the band (a sphere's is smaller than it).

    The slice's corners are vertices inside the band or points where a segment between two vertices
    crosses one of the band's planes; every such point lies in the solid, so the hull is exact.
    """
    z = vertices[:, 2]
    points = [vertices[(z >= band[0]) & (z <= band[1]), :2]]
    for height in band:
        below, above = vertices[z < height], vertices[z > height]
        if len(below) == 0 or len(above) == 0:
            continue
        t = (height - below[:, None, 2]) / (above[None, :, 2] - below[:, None, 2])
        points.append(
            (below[:, None, :2] + t[..., None] * (above[None, :, :2] - below[:, None, :2])).reshape(-1, 2)
        )
    return np.concatenate(points)


def _convex_hull(points: np.ndarray) -> np.ndarray:
    """Monotone-chain convex hull, counter-clockwise."""
    ordered = sorted({(round(float(x), 6), round(float(y), 6)) for x, y in points})

    def half(sequence):
        chain: list[tuple[float, float]] = []
        for point in sequence:
            while len(chain) >= 2 and _cross(chain[-2], chain[-1], point) <= 0:
                chain.pop()
            chain.append(point)
        return chain

    lower, upper = half(ordered), half(reversed(ordered))
    return np.array(lower[:-1] + upper[:-1])


def _cross(o, a, b) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def distance_to_polygons(
    points: np.ndarray, polygons: list[np.ndarray], within: float = np.inf
) -> np.ndarray:
    """Distance from each 2D point to the nearest polygon (0 inside one).

    Only distances below ``within`` are exact; a point farther than that from every polygon's
    bounding box keeps inf (the culling that makes a fine grid affordable).
    """
    points = np.asarray(points, np.float64).reshape(-1, 2)
    best = np.full(len(points), np.inf)
    for polygon in polygons:
        low, high = polygon.min(axis=0) - within, polygon.max(axis=0) + within
        near = np.flatnonzero(np.all((points >= low) & (points <= high), axis=1))
        if len(near) == 0:
            continue
        subset = points[near]
        a, b = polygon, np.roll(polygon, -1, axis=0)
        edge = b - a
        t = np.einsum("nkd,kd->nk", subset[:, None] - a, edge) / np.maximum((edge**2).sum(1), 1e-12)
        nearest = a + np.clip(t, 0, 1)[..., None] * edge
        distance = np.linalg.norm(subset[:, None] - nearest, axis=2).min(axis=1)
        side = edge[:, 0] * (subset[:, None, 1] - a[:, 1]) - edge[:, 1] * (subset[:, None, 0] - a[:, 0])
        inside = np.all(side >= 0, axis=1)
        best[near] = np.minimum(best[near], np.where(inside, 0.0, distance))
    return best


def disc_collides(points: np.ndarray, polygons: list[np.ndarray], radius: float) -> np.ndarray:
    return distance_to_polygons(points, polygons, within=radius) < radius


def true_shortest(
    solids: list[np.ndarray],
    start: np.ndarray,
    goal: np.ndarray,
    radius: float,
    band: tuple[float, float],
    bounds: tuple[np.ndarray, np.ndarray],
) -> float | None:
    """Length of the shortest collision-free route for a disc on the true footprints, or None."""
    polygons = footprints(solids, band)
    low, high = np.asarray(bounds[0], float)[:2], np.asarray(bounds[1], float)[:2]
    columns = np.arange(low[0], high[0] + _TRUTH_CELL, _TRUTH_CELL)
    rows = np.arange(low[1], high[1] + _TRUTH_CELL, _TRUTH_CELL)
    xx, yy = np.meshgrid(columns, rows)
    clear = distance_to_polygons(np.stack([xx.ravel(), yy.ravel()], axis=1), polygons, within=radius)
    clear = clear.reshape(xx.shape)
    passable = clear >= radius
    cell_of = lambda p: (int(round((p[1] - low[1]) / _TRUTH_CELL)), int(round((p[0] - low[0]) / _TRUTH_CELL)))  # noqa: E731
    path = astar(passable, cell_of(start), cell_of(goal))
    if path is None:
        return None
    corners = np.array(shorten(passable, path))[:, ::-1] * _TRUTH_CELL + low
    corners[0], corners[-1] = start[:2], goal[:2]
    return float(np.linalg.norm(np.diff(corners, axis=0), axis=1).sum())


def _box_solid(
    builder: _Builder, solids: list, material: int, size, centre_xy, yaw: float = 0.0, z: float = 0.0
):
    mesh = _box(*size, z=z)
    vertices = np.asarray(mesh.vertices) @ _yaw_matrix(yaw).T + [centre_xy[0], centre_xy[1], 0.0]
    builder.add(vertices, np.asarray(mesh.triangles), ROOM_OBJECT_ID, material)
    solids.append(vertices)


def _add_shell(
    builder: _Builder, solids: list, length: float, width: float, door: tuple[float, float], divider: float
):
    """Floor, the outer walls (inner faces drawn, slabs outside as solids) and the dividing wall."""
    height = 2.8
    floor = builder.material("floor", (0.72, 0.62, 0.5), 0.4, 0.11)
    builder.add_quad(np.array([[0, 0, 0], [length, 0, 0], [length, width, 0], [0, width, 0]]), floor)
    corners = [(0, 0), (length, 0), (length, width), (0, width)]
    colours = [(0.8, 0.78, 0.7), (0.66, 0.76, 0.8), (0.82, 0.7, 0.68), (0.7, 0.8, 0.68)]
    for k, rgb in enumerate(colours):
        (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % 4]
        wall = builder.material(f"wall {k}", rgb, 0.45, 0.12)
        builder.add_quad(np.array([[x0, y0, 0], [x1, y1, 0], [x1, y1, height], [x0, y0, height]]), wall)
    for x0, y0, x1, y1 in (
        (-WALL, -WALL, length + WALL, 0),
        (-WALL, width, length + WALL, width + WALL),
        (-WALL, 0, 0, width),
        (length, 0, length + WALL, width),
    ):
        solids.append(np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (0, height)]))
    divider_material = builder.material("dividing wall", (0.78, 0.74, 0.66), 0.4, 0.1)
    for y0, y1 in ((0.0, door[0]), (door[1], width)):
        if y1 - y0 > 1e-6:
            _box_solid(builder, solids, divider_material, (WALL, y1 - y0, height), (divider, 0.5 * (y0 + y1)))


def _view(eye_xy, look_xy, height: float = EYE_HEIGHT) -> np.ndarray:
    eye = np.array([eye_xy[0], eye_xy[1], height])
    horizontal = np.asarray(look_xy, float) - eye[:2]
    horizontal /= np.linalg.norm(horizontal)
    drop = np.tan(np.radians(_PITCH_DOWN_DEG))
    return look_at(eye, eye + np.append(horizontal, -drop))


def robot_view(two: TwoRoomScene, xy: np.ndarray, heading: float) -> np.ndarray:
    """3x4 camera-from-world (OpenCV axes) of the scene's camera above floor point ``xy``, facing
    ``heading`` (radians about +z from +x), pitched down as the generator's views are."""
    xy = np.asarray(xy, np.float64)
    return _view(xy, xy + np.array([np.cos(heading), np.sin(heading)]), two.camera_height)


@dataclass
class _Layout:
    length: float
    width: float
    divider: float
    door: tuple[float, float]
    eyes: list[np.ndarray]  # (2,) floor positions of the cameras
    looks: list[np.ndarray]  # (2,) where each camera looks
    goal: np.ndarray  # (2,)
    heights: list[float] | None = None  # per view camera height; None: EYE_HEIGHT
    goal_view: int = 3
    coverage: str = "fixed"
    door_keep_out: float = 1.4  # furniture keeps this far from the doorway's centre
    goal_margin: float = 0.8  # the goal keeps this far from room B's walls


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    cosine = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def _start_heading(rng: np.random.Generator, coverage: str, start: np.ndarray, beyond) -> float:
    """The start view's heading; with the floor past the doorway hidden, it faces away from the wall."""
    if coverage not in ("none", "doorway"):
        return float(rng.uniform(0, 2 * np.pi))
    for _ in range(20):
        heading = float(rng.uniform(0.6 * np.pi, 1.4 * np.pi))
        if coverage == "none" or not _frustum_meets(start, start + _unit(heading), beyond):
            break
    return heading


def _beside_the_doorway(rng: np.random.Generator, layout: _Layout) -> tuple[np.ndarray, np.ndarray]:
    """(eye, look) of a room A view of the dividing wall beside the doorway, not through it."""
    divider, width, door_centre = layout.divider, layout.width, 0.5 * sum(layout.door)
    offset = float(rng.choice([-1, 1]) * rng.uniform(1.7, 2.3))
    if not 0.5 <= door_centre + offset <= width - 0.5:
        offset = -offset
    target_y = float(np.clip(door_centre + offset, 0.5, width - 0.5))
    eye = np.array([divider - rng.uniform(0.9, 1.3), target_y + 0.2 * np.sign(offset)])
    return eye, np.array([divider, target_y])


def _varied_views(rng: np.random.Generator, layout: _Layout, start: np.ndarray) -> None:
    """Replace the fixed capture by a drawn one: 3-7 views, one height, a doorway coverage."""
    divider, width, length = layout.divider, layout.width, layout.length
    door_centre = 0.5 * sum(layout.door)
    coverage = str(rng.choice(list(COVERAGES)))
    hides_beyond = coverage in ("none", "doorway")  # no view may see room B's floor by the doorway
    beyond = _beyond_the_doorway(layout)
    heading = _start_heading(rng, coverage, start, beyond)
    eyes = [start]
    looks = [start + _unit(heading)]
    if coverage == "none":  # room B's view stands near the dividing wall and looks away from it
        far_end = 0.8 if door_centre > width / 2 else width - 0.8  # the end of the wall away from the door
        eyes.append(np.array([divider + WALL / 2 + 0.6, far_end]))
    elif coverage == "doorway":
        _goal_away_from_the_doorway(rng, layout)
        eye, look = _goal_view_missing(rng, layout, beyond)
        eyes.append(eye)
    else:
        eyes.append(_farthest_corner(layout.goal, divider + WALL / 2, length, width))
    looks.append(layout.goal if coverage != "doorway" else look)
    if coverage in ("full", "partial"):
        shift = 0.0 if coverage == "full" else float(rng.choice([-1, 1]) * rng.uniform(0.8, 1.6))
        eyes.append(np.array([divider - rng.uniform(1.8, 3.0), door_centre + rng.uniform(-0.5, 0.5)]))
        looks.append(np.array([divider + 1.5, door_centre + shift]))
    if coverage in ("none", "doorway"):  # the wall beside the doorway, or along it: not through it
        eye, look = _beside_the_doorway(rng, layout) if coverage == "none" else _along_the_wall(rng, layout)
        eyes.append(eye)
        looks.append(look)
    if coverage == "full":
        eyes.append(np.array([divider + rng.uniform(1.8, 3.0), door_centre + rng.uniform(-0.5, 0.5)]))
        looks.append(np.array([divider - 1.5, door_centre]))
    side = float(rng.choice([-1.0, 1.0]))
    extras = [
        (_farthest_corner(start, 0.0, divider - WALL / 2, width), start),
        (np.array([divider - 0.8, width / 2 + side * (width / 2 - 0.7)]), np.array([divider / 2, width / 2])),
    ]
    if not hides_beyond:  # a view from room B's far end would see the floor past the doorway
        b_corner = np.array([length - 0.7, width / 2 - side * (width / 2 - 0.7)])
        extras.append((b_corner, np.array([(divider + length) / 2, width / 2])))
    wanted = int(rng.integers(max(0, 3 - len(eyes)), min(len(extras), 7 - len(eyes)) + 1))
    door = np.array([divider, door_centre])
    for index in rng.permutation(len(extras))[:wanted]:
        eye, look = extras[index]
        if hides_beyond and _angle_deg(look - eye, door - eye) < 55.0:
            continue  # it would look through the doorway
        eyes.append(eye)
        looks.append(look)
    if len(eyes) < 3:  # the start area, seen from just behind the start
        eyes.append(start - 0.8 * _unit(heading))
        looks.append(start + _unit(heading))
    height = float(rng.uniform(1.0, 1.8))
    layout.heights = [height] + [
        float(np.clip(height + rng.uniform(-0.15, 0.15), 0.9, 1.9)) for _ in eyes[1:]
    ]
    layout.eyes, layout.looks, layout.goal_view, layout.coverage = eyes, looks, 1, coverage
    layout.door_keep_out = float(rng.uniform(0.5, 1.4))


def _unit(angle: float) -> np.ndarray:
    return np.array([np.cos(angle), np.sin(angle)])


def _beyond_the_doorway(layout: _Layout) -> np.ndarray:
    """Floor points just past the doorway in room B: 1.2 m deep, a metre wider than it each side."""
    xs = np.linspace(layout.divider + WALL / 2, layout.divider + WALL / 2 + 1.2, 7)
    ys = np.linspace(layout.door[0] - 1.0, layout.door[1] + 1.0, 12)
    return np.array([[x, y] for x in xs for y in ys])


def _frustum_meets(eye: np.ndarray, look: np.ndarray, floor_points: np.ndarray, count: bool = False):
    """Whether a view (at any camera height the generator draws) has any of the floor points in frame.

    Occlusion is ignored, so False means the view cannot see them. ``count``: how many are.
    """
    intrinsic = default_intrinsic(320, 240, _FOV_DEG)
    points = np.column_stack([floor_points, np.zeros(len(floor_points))])
    total = 0
    for height in (0.9, 1.9):
        pose = _view(eye, look, height)
        camera = points @ pose[:, :3].T + pose[:, 3]
        front = camera[:, 2] > 1e-6
        pixels = camera[front] @ intrinsic.T
        u, v = pixels[:, 0] / pixels[:, 2], pixels[:, 1] / pixels[:, 2]
        framed = int(np.count_nonzero((u >= -10) & (u <= 330) & (v >= -10) & (v <= 250)))
        if framed and not count:
            return True
        total += framed
    return total if count else False


def _goal_view_missing(
    rng: np.random.Generator, layout: _Layout, beyond: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Where room B's view of the goal stands so that the floor by the doorway is out of its frame.

    Candidates: room B's corners, then points 2.4 or 3 m around the goal, each in a drawn order,
    looking at the goal or up to 28 degrees beside it; the first at least 2.1 m from the goal
    (nearer, a pen's near side would be below the frame) whose frame holds none of ``beyond``.
    Returns (eye, look).
    """
    x0, x1 = layout.divider + WALL / 2 + 0.7, layout.length - 0.7
    corners = [np.array([x, y]) for x in (x0, x1) for y in (0.7, layout.width - 0.7)]
    around = [
        np.clip(layout.goal + distance * _unit(angle), [x0, 0.7], [x1, layout.width - 0.7])
        for distance in (2.4, 3.0)
        for angle in np.radians(np.arange(0, 360, 30))
    ]
    candidates = [corners[i] for i in rng.permutation(4)] + [around[i] for i in rng.permutation(len(around))]
    best, fewest = None, np.inf
    for eye in candidates:
        if np.linalg.norm(eye - layout.goal) < 2.1:
            continue  # closer, the floor a metre before the goal (a pen's near side) is below the frame
        towards = layout.goal - eye
        for swing in np.radians([0.0, 15.0, -15.0, 28.0, -28.0]):  # the goal off the frame's centre
            cosine, sine = np.cos(swing), np.sin(swing)
            look = eye + np.array(
                [cosine * towards[0] - sine * towards[1], sine * towards[0] + cosine * towards[1]]
            )
            framed = _frustum_meets(eye, look, beyond, count=True)
            if framed < fewest:
                best, fewest = (eye, look), framed
            if framed == 0:
                return eye, look
    return best  # the fewest such floor points in frame (the bench measures what was seen)


def _goal_away_from_the_doorway(rng: np.random.Generator, layout: _Layout) -> None:
    """Redraw the goal at least 2.6 m from the doorway: a view framing a goal beside it frames its floor."""
    door = np.array([layout.divider, 0.5 * sum(layout.door)])
    margin = layout.goal_margin
    low, high = [layout.divider + 1.5, margin], [layout.length - margin, layout.width - margin]
    for _ in range(50):
        if np.linalg.norm(layout.goal - door) >= 2.6:
            return
        layout.goal = rng.uniform(low, high)


def _along_the_wall(rng: np.random.Generator, layout: _Layout) -> tuple[np.ndarray, np.ndarray]:
    """A room A view along the dividing wall that frames both jambs but sees nothing through the gap.

    A camera ``a`` metres from the wall's face and ``s`` metres along it from the near jamb sees
    through the doorway (width ``w``, wall ``WALL`` thick) only when ``a * w >= WALL * s``: standing
    closer to the wall than ``WALL * s / w``, every ray into the gap meets the far jamb's end face.
    """
    low, high = layout.door
    door_width = high - low
    room_below, room_above = low - 0.5, layout.width - 0.5 - high
    sign = -1.0 if room_below >= room_above else 1.0  # stand on the side with more wall
    along = float(rng.uniform(0.75, 1.0)) * max(room_below, room_above)
    along = min(along, 3.4)
    off_wall = float(rng.uniform(0.45, 0.8)) * WALL * along / door_width
    near_jamb = low if sign < 0 else high
    eye = np.array([layout.divider - WALL / 2 - off_wall, near_jamb + sign * along])
    door = np.array([layout.divider, 0.5 * (low + high)])
    towards = (door - eye) / np.linalg.norm(door - eye)
    turn = np.radians(float(rng.uniform(8.0, 18.0)))  # a little into room A, the jambs still in frame
    into_a = -sign  # looking +y (from below the doorway) a counter-clockwise turn faces -x, room A
    cosine, sine = np.cos(into_a * turn), np.sin(into_a * turn)
    look = eye + 2.0 * np.array(
        [cosine * towards[0] - sine * towards[1], sine * towards[0] + cosine * towards[1]]
    )
    return eye, look


def _layout(rng: np.random.Generator, kind: str, varied: bool = False) -> _Layout:
    length, width = float(rng.uniform(9.5, 11.0)), float(rng.uniform(4.6, 5.3))
    divider = length * float(rng.uniform(0.45, 0.55))
    door_width = float(rng.uniform(0.3, 0.42)) if kind == "narrow_door" else float(rng.uniform(0.9, 1.2))
    door_centre = float(rng.uniform(1.3, width - 1.3))
    door = (door_centre - door_width / 2, door_centre + door_width / 2)
    a_centre, b_centre = np.array([divider / 2, width / 2]), np.array([(divider + length) / 2, width / 2])
    margin = 1.5 if kind == "ring" else 0.8
    goal = rng.uniform([divider + 1.5, margin], [length - margin, width - margin])
    start = rng.uniform([0.9, 0.9], [divider - 1.2, width - 0.9])
    heading = float(rng.uniform(0, 2 * np.pi))
    side = float(rng.choice([-1.0, 1.0]))
    eyes = [
        start,
        np.array([divider - 2.2, door_centre + rng.uniform(-0.5, 0.5)]),
        np.array([divider + 2.2, door_centre + rng.uniform(-0.5, 0.5)]),
        _farthest_corner(goal, divider + WALL / 2, length, width),
        _farthest_corner(start, 0.0, divider - WALL / 2, width),
    ]
    looks = [
        start + [np.cos(heading), np.sin(heading)],
        np.array([divider + 1.5, door_centre]),
        np.array([divider - 1.5, door_centre]),
        goal,
        start,  # the floor around the robot: the start view itself sees it only from a metre ahead
    ]
    extras = [
        (np.array([length - 0.7, width / 2 + side * (width / 2 - 0.7)]), b_centre),
        (np.array([divider - 0.8, width / 2 + side * (width / 2 - 0.7)]), a_centre),
    ]
    for index in rng.permutation(len(extras))[: int(rng.integers(0, len(extras) + 1))]:
        eyes.append(extras[index][0])
        looks.append(extras[index][1])
    layout = _Layout(length, width, divider, door, eyes, looks, goal, goal_margin=margin)
    if varied:
        _varied_views(rng, layout, start)
    return layout


def _farthest_corner(point: np.ndarray, x0: float, x1: float, width: float) -> np.ndarray:
    """The corner of the room [x0, x1] x [0, width] (0.7 m in from its walls) farthest from a point."""
    corners = np.array([[x, y] for x in (x0 + 0.7, x1 - 0.7) for y in (0.7, width - 0.7)])
    return corners[int(np.argmax(np.linalg.norm(corners - point, axis=1)))]


def _add_pen(builder: _Builder, solids: list, goal: np.ndarray) -> None:
    """Four low partitions closing a square around the goal (overlapping at the corners)."""
    material = builder.material("low partition", (0.55, 0.55, 0.6), 0.2, 0.06)
    # Low enough for the views to see the floor inside over them, high enough to meet the robot's body.
    half, thickness, height = 0.75, 0.15, 0.3
    span = 2 * half + 2 * thickness
    for dx, dy, sx, sy in (
        (0, half + thickness / 2, span, thickness),
        (0, -half - thickness / 2, span, thickness),
        (half + thickness / 2, 0, thickness, span),
        (-half - thickness / 2, 0, thickness, span),
    ):
        _box_solid(builder, solids, material, (sx, sy, height), goal + [dx, dy])


def _clear_of(xy: np.ndarray, radius: float, keep_out: list[tuple[np.ndarray, float]]) -> bool:
    return all(np.linalg.norm(xy - p) >= radius + r for p, r in keep_out)


def _add_furniture(
    builder: _Builder, solids: list, rng: np.random.Generator, layout: _Layout, objects: list[SceneObject]
) -> None:
    keep_out = [(eye, 0.7) for eye in layout.eyes] + [(layout.goal, 1.1)]
    keep_out.append((np.array([layout.divider, 0.5 * sum(layout.door)]), layout.door_keep_out))
    rooms = [(0.0, layout.divider - WALL / 2), (layout.divider + WALL / 2, layout.length)]
    for entry_index in rng.permutation(len(CATALOGUE))[: int(rng.integers(4, 7))]:
        entry = CATALOGUE[entry_index]
        yaw = float(rng.uniform(0, 360))
        parts = [
            (np.asarray(mesh.vertices) @ _yaw_matrix(yaw).T, mesh, rgb)
            for mesh, rgb in entry.build(entry.rgb)
        ]
        local = np.concatenate([v for v, _, _ in parts])
        radius = float(0.5 * np.hypot(*np.ptp(local[:, :2], axis=0)))
        x0, x1 = rooms[len(objects) % 2]
        for _ in range(100):
            xy = rng.uniform(
                [x0 + radius + 0.1, radius + 0.1], [x1 - radius - 0.1, layout.width - radius - 0.1]
            )
            if _clear_of(xy, radius, keep_out):
                break
        else:
            continue
        keep_out.append((xy, radius + 0.1))
        material = builder.material(entry.name, entry.rgb, 0.2, 0.06)
        world = []
        for vertices, mesh, _ in parts:
            placed = vertices + [xy[0], xy[1], 0.0]
            builder.add(placed, np.asarray(mesh.triangles), len(objects), material)
            solids.append(placed)
            world.append(placed)
        world = np.concatenate(world)
        low, high = world.min(axis=0), world.max(axis=0)
        objects.append(SceneObject(entry.name, (low + high) / 2, high - low, yaw))


def _build(seed: int, kind: str, size: tuple[int, int], varied: bool = False) -> TwoRoomScene:
    rng = np.random.default_rng(seed)
    layout = _layout(rng, kind, varied)
    builder, solids, objects = _Builder(rng), [], []
    _add_shell(builder, solids, layout.length, layout.width, layout.door, layout.divider)
    if kind == "ring":
        _add_pen(builder, solids, layout.goal)
    _add_furniture(builder, solids, rng, layout, objects)
    scene = builder.scene(seed, objects, np.array([layout.length, layout.width, 2.8]), has_ceiling=False)
    heights = layout.heights or [EYE_HEIGHT] * len(layout.eyes)
    extrinsics = np.array(
        [_view(eye, look, h) for eye, look, h in zip(layout.eyes, layout.looks, heights, strict=True)]
    )
    return TwoRoomScene(
        scene=scene,
        kind=kind,
        solids=solids,
        extrinsics=extrinsics,
        intrinsic=default_intrinsic(size[0], size[1], _FOV_DEG),
        size=size,
        goal=np.append(layout.goal, 0.0),
        door=layout.door,
        divider_x=layout.divider,
        goal_view=layout.goal_view,
        camera_height=heights[0],
        coverage=layout.coverage,
    )


def _fits_its_kind(two: TwoRoomScene, radius: float, band: tuple[float, float]) -> bool:
    polygons = footprints(two.solids, band)
    ends = np.stack([two.start_floor()[:2], two.goal[:2]])
    if disc_collides(ends, polygons, radius + 0.1).any():
        return False  # start and goal stand in the open, so a refusal is about the way between
    shortest = true_shortest(
        two.solids, two.start_floor(), two.goal, radius, band, (two.scene.room_min, two.scene.room_max)
    )
    return (shortest is not None) == (two.kind == "reachable")


def generate_two_rooms(
    seed: int,
    kind: str = "reachable",
    size: tuple[int, int] = (320, 240),
    radius: float = 0.25,
    band: tuple[float, float] = (0.05, 0.5),
    varied: bool = False,
) -> TwoRoomScene:
    """A two-room scene of this kind (``KINDS``), deterministic for a seed (``varied``: see above).

    Layouts are drawn until one is what its kind says on the true geometry for a robot of this
    radius and body band (a reachable scene has a route; the others have none).
    """
    if kind not in KINDS:
        raise ValueError(f"unknown kind {kind!r}; expected one of {KINDS}")
    for attempt in range(40):
        sub_seed = int(np.random.SeedSequence([seed, KINDS.index(kind), attempt]).generate_state(1)[0])
        two = _build(sub_seed, kind, size, varied)
        if _fits_its_kind(two, radius, band):
            return two
    raise ValueError(f"seed {seed}: no {kind} layout found")


def past_the_doorway(two: TwoRoomScene, depth_m: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The floor box (x, y low), (x, y high) just past the doorway, the whole width of room B."""
    low = np.array([two.divider_x + WALL / 2, float(two.scene.room_min[1])])
    return low, np.array([low[0] + depth_m, float(two.scene.room_max[1])])


def depths_without_floor_past_the_doorway(two: TwoRoomScene, views, depth_m: float = 1.0) -> list[np.ndarray]:
    """Every view's depth with its floor pixels past the doorway blanked (0: no depth there).

    A capture in which no view saw the floor just beyond the doorway, everything else as rendered.
    """
    low, high = past_the_doorway(two, depth_m)
    depths = []
    for pose, view in zip(two.extrinsics, views, strict=True):
        depth = view.depth.copy()
        rows, columns = np.indices(depth.shape)
        rays = np.stack([columns, rows, np.ones_like(rows)], axis=-1) @ np.linalg.inv(two.intrinsic).T
        world = (rays * depth[..., None] - pose[:, 3]) @ pose[:, :3]
        inside = np.all((world[..., :2] >= low) & (world[..., :2] <= high), axis=-1)
        depth[(np.abs(world[..., 2]) < 0.03) & inside] = 0.0
        depths.append(depth)
    return depths


@dataclass
class Execution:
    end: np.ndarray  # (2,) where the robot stopped
    collided: bool
    first_collision: np.ndarray | None  # (2,) where the disc first touched a true footprint
    length: float


def drive(
    position: np.ndarray, heading: float, moves: list[tuple[float, float]], step_m: float
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Samples of the robot's centre on the floor every ``step_m`` along (turn_degrees, metres)
    moves (left-positive turns about +z, heading in radians from +x), after the start point; the
    end position, heading and the metres driven."""
    samples, length = [np.zeros((0, 2))], 0.0
    position = np.asarray(position, np.float64)
    for turn, move in moves:
        heading += np.radians(turn)
        direction = np.array([np.cos(heading), np.sin(heading)])
        count = max(int(np.ceil(abs(move) / step_m)), 1)
        samples.append(position + np.linspace(0.0, move, count + 1)[1:, None] * direction)
        position = position + move * direction
        length += abs(move)
    return np.concatenate(samples), position, heading, length


def execute_steps(
    two: TwoRoomScene,
    steps: list[dict],
    radius: float,
    band: tuple[float, float] = (0.05, 0.5),
    step_m: float = 0.02,
) -> Execution:
    """Drive the steps from the true start pose (left-positive turns about +z) on the true geometry.

    The disc is checked every ``step_m`` along each move; a collision is any overlap with a true
    footprint at body height.
    """
    polygons = footprints(two.solids, band)
    forward = two.extrinsics[0][2, :2]
    heading = float(np.arctan2(forward[1], forward[0]))
    position_at_start = two.start_floor()[:2].astype(np.float64)
    moves = [(float(step["turn_degrees"]), float(step["move"])) for step in steps]
    after_start, position, _heading, length = drive(position_at_start, heading, moves, step_m)
    trace = np.concatenate([position_at_start[None], after_start])
    hits = disc_collides(trace, polygons, radius)
    first = trace[int(np.argmax(hits))] if hits.any() else None
    return Execution(end=position, collided=bool(hits.any()), first_collision=first, length=length)
