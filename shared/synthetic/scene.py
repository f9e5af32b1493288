"""Procedural indoor rooms with named furniture and exact geometry.

World frame: **z is up**, the floor is the plane z = 0 and the room spans
[room_min, room_max]. Cameras looking into the room are OpenCV camera-from-world extrinsics
(see docs/ARCHITECTURE.md); ``render.look_at`` builds them.

Every surface has a *material*: a base colour plus the parameters of a procedural texture
(see ``texture.py``), so the renderer can colour any hit point deterministically.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import open3d as o3d

from shared.synthetic.texture import Material, material_table

WORLD_UP = np.array([0.0, 0.0, 1.0])
ROOM_OBJECT_ID = -1
# The disc around the room centre is kept free of furniture so a camera can turn in place there.
CLEAR_RADIUS = 1.0
_GAP_BETWEEN_OBJECTS = 0.35
_WALL_MARGIN = 0.3


@dataclass(frozen=True)
class SceneObject:
    name: str
    centre: np.ndarray  # (3,) world centre of the axis-aligned bounding box
    size: np.ndarray  # (3,) extent of that box along x, y, z
    yaw_deg: float  # rotation about the up axis applied to the catalogue model

    @property
    def footprint_radius(self) -> float:
        return float(0.5 * np.hypot(self.size[0], self.size[1]))


@dataclass(eq=False)
class SyntheticScene:
    seed: int
    vertices: np.ndarray  # (V, 3) float32 world coordinates
    triangles: np.ndarray  # (T, 3) int32
    triangle_object_ids: np.ndarray  # (T,) int32, ROOM_OBJECT_ID for floor/walls/ceiling
    triangle_material_ids: np.ndarray  # (T,) int32 index into materials
    materials: list[Material]
    objects: list[SceneObject]
    room_min: np.ndarray  # (3,)
    room_max: np.ndarray  # (3,)
    has_ceiling: bool
    up: np.ndarray = field(default_factory=lambda: WORLD_UP.copy())

    @property
    def object_names(self) -> list[str]:
        return [obj.name for obj in self.objects]

    @property
    def object_centres(self) -> np.ndarray:
        return np.array([obj.centre for obj in self.objects]).reshape(-1, 3)

    @property
    def object_sizes(self) -> np.ndarray:
        return np.array([obj.size for obj in self.objects]).reshape(-1, 3)

    @property
    def room_centre(self) -> np.ndarray:
        return 0.5 * (self.room_min + self.room_max)

    def mesh(self, object_id: int | None = None) -> o3d.geometry.TriangleMesh:
        """The whole scene (or one object, or the room with ROOM_OBJECT_ID) as a legacy mesh."""
        keep = np.ones(len(self.triangles), bool)
        if object_id is not None:
            keep = self.triangle_object_ids == object_id
        mesh = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(self.vertices.astype(np.float64)),
            o3d.utility.Vector3iVector(self.triangles[keep]),
        )
        mesh.remove_unreferenced_vertices()
        return mesh

    @cached_property
    def material_table(self) -> dict[str, np.ndarray]:
        return material_table(self.materials)

    @cached_property
    def raycasting_scene(self) -> o3d.t.geometry.RaycastingScene:
        # Built once per scene; every render reuses the same acceleration structure.
        raycaster = o3d.t.geometry.RaycastingScene()
        raycaster.add_triangles(
            o3d.core.Tensor(self.vertices.astype(np.float32)),
            o3d.core.Tensor(self.triangles.astype(np.uint32)),
        )
        return raycaster


# ---------------------------------------------------------------------------------------------
# Catalogue: each model is a list of (part mesh, part colour) sitting on z = 0, centred on x/y.


Part = tuple[o3d.geometry.TriangleMesh, tuple[float, float, float]]


def _box(sx: float, sy: float, sz: float, x: float = 0.0, y: float = 0.0, z: float = 0.0):
    """Axis-aligned box of size (sx, sy, sz) whose bottom face is centred on (x, y, z)."""
    mesh = o3d.geometry.TriangleMesh.create_box(sx, sy, sz)
    return mesh.translate((x - sx / 2, y - sy / 2, z))


def _cylinder(radius: float, height: float, z: float = 0.0, resolution: int = 24):
    mesh = o3d.geometry.TriangleMesh.create_cylinder(radius, height, resolution=resolution, split=1)
    return mesh.translate((0.0, 0.0, z + height / 2))


def _sphere(radius: float, z: float):
    return o3d.geometry.TriangleMesh.create_sphere(radius, resolution=16).translate((0.0, 0.0, z))


def _legs(width: float, depth: float, height: float, thickness: float):
    inset_x, inset_y = width / 2 - thickness / 2, depth / 2 - thickness / 2
    return [
        _box(thickness, thickness, height, sx * inset_x, sy * inset_y) for sx in (-1, 1) for sy in (-1, 1)
    ]


def _sofa(c):
    return [
        (_box(2.0, 0.9, 0.45), c),
        (_box(2.0, 0.2, 0.5, y=0.35, z=0.45), c),
        (_box(0.2, 0.9, 0.25, x=-0.9, z=0.45), c),
        (_box(0.2, 0.9, 0.25, x=0.9, z=0.45), c),
    ]


def _table(c):
    return [(_box(1.4, 0.8, 0.06, z=0.7), c)] + [(leg, c) for leg in _legs(1.4, 0.8, 0.7, 0.08)]


def _chair(c):
    seat = [(_box(0.5, 0.5, 0.06, z=0.45), c), (_box(0.5, 0.06, 0.5, y=0.22, z=0.51), c)]
    return seat + [(leg, c) for leg in _legs(0.5, 0.5, 0.45, 0.06)]


def _armchair(c):
    return [
        (_box(0.9, 0.85, 0.45), c),
        (_box(0.9, 0.2, 0.5, y=0.33, z=0.45), c),
        (_box(0.15, 0.85, 0.2, x=-0.375, z=0.45), c),
        (_box(0.15, 0.85, 0.2, x=0.375, z=0.45), c),
    ]


def _plant(c):
    return [(_cylinder(0.2, 0.45), (0.62, 0.32, 0.2)), (_sphere(0.42, 0.85), c)]


def _lamp(c):
    return [
        (_cylinder(0.2, 0.04), (0.2, 0.2, 0.2)),
        (_cylinder(0.035, 1.35, z=0.04), (0.25, 0.25, 0.25)),
        (_cylinder(0.25, 0.35, z=1.3), c),
    ]


def _tv(c):
    return [(_box(1.5, 0.45, 0.5), (0.45, 0.3, 0.2)), (_box(1.2, 0.08, 0.72, z=0.5), c)]


def _trash_can(c):
    return [(_cylinder(0.22, 0.55), c)]


def _ball(c):
    return [(_sphere(0.3, 0.3), c)]


def _simple_box(sx, sy, sz):
    return lambda c: [(_box(sx, sy, sz), c)]


@dataclass(frozen=True)
class CatalogueEntry:
    name: str
    rgb: tuple[float, float, float]
    build: Callable[[tuple[float, float, float]], list[Part]]


CATALOGUE: tuple[CatalogueEntry, ...] = (
    CatalogueEntry("red sofa", (0.78, 0.14, 0.13), _sofa),
    CatalogueEntry("wooden table", (0.6, 0.4, 0.2), _table),
    CatalogueEntry("blue chair", (0.16, 0.32, 0.82), _chair),
    CatalogueEntry("green plant", (0.2, 0.62, 0.22), _plant),
    CatalogueEntry("floor lamp", (0.95, 0.85, 0.45), _lamp),
    CatalogueEntry("bookshelf", (0.42, 0.26, 0.14), _simple_box(1.0, 0.38, 1.9)),
    CatalogueEntry("tv", (0.12, 0.12, 0.14), _tv),
    CatalogueEntry("cardboard box", (0.78, 0.6, 0.38), _simple_box(0.6, 0.6, 0.5)),
    CatalogueEntry("white fridge", (0.92, 0.92, 0.9), _simple_box(0.75, 0.7, 1.8)),
    CatalogueEntry("yellow ball", (0.95, 0.82, 0.1), _ball),
    CatalogueEntry("orange cabinet", (0.92, 0.5, 0.12), _simple_box(0.9, 0.5, 1.0)),
    CatalogueEntry("purple armchair", (0.5, 0.22, 0.6), _armchair),
    CatalogueEntry("gray trash can", (0.5, 0.5, 0.52), _trash_can),
)


# ---------------------------------------------------------------------------------------------


class _Builder:
    """Accumulates triangles with their object and material ids."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng
        self.vertices: list[np.ndarray] = []
        self.triangles: list[np.ndarray] = []
        self.object_ids: list[np.ndarray] = []
        self.material_ids: list[np.ndarray] = []
        self.materials: list[Material] = []
        self._vertex_count = 0

    def material(self, name: str, rgb: tuple[float, float, float], coarse: float, fine: float) -> int:
        rotation, _ = np.linalg.qr(self.rng.normal(size=(3, 3)))
        salt = int(self.rng.integers(1, 2**31 - 1))
        self.materials.append(Material(name, tuple(rgb), salt, rotation, coarse, fine))
        return len(self.materials) - 1

    def add(self, vertices: np.ndarray, triangles: np.ndarray, object_id: int, material_id: int) -> None:
        self.vertices.append(np.asarray(vertices, np.float64))
        self.triangles.append(np.asarray(triangles, np.int64) + self._vertex_count)
        self.object_ids.append(np.full(len(triangles), object_id, np.int32))
        self.material_ids.append(np.full(len(triangles), material_id, np.int32))
        self._vertex_count += len(vertices)

    def add_quad(self, corners: np.ndarray, material_id: int) -> None:
        self.add(corners, np.array([[0, 1, 2], [0, 2, 3]]), ROOM_OBJECT_ID, material_id)

    def scene(
        self, seed: int, objects: list[SceneObject], room_max: np.ndarray, has_ceiling: bool
    ) -> SyntheticScene:
        """The accumulated mesh as a scene whose room spans from the origin to `room_max`."""
        return SyntheticScene(
            seed=seed,
            vertices=np.concatenate(self.vertices).astype(np.float32),
            triangles=np.concatenate(self.triangles).astype(np.int32),
            triangle_object_ids=np.concatenate(self.object_ids),
            triangle_material_ids=np.concatenate(self.material_ids),
            materials=self.materials,
            objects=objects,
            room_min=np.zeros(3),
            room_max=room_max,
            has_ceiling=has_ceiling,
        )


def _add_room(builder: _Builder, size: np.ndarray, has_ceiling: bool) -> None:
    sx, sy, sz = size
    floor = builder.material("floor", (0.72, 0.62, 0.5), 0.4, 0.11)
    builder.add_quad(np.array([[0, 0, 0], [sx, 0, 0], [sx, sy, 0], [0, sy, 0]]), floor)
    wall_colours = [(0.8, 0.78, 0.7), (0.66, 0.76, 0.8), (0.82, 0.7, 0.68), (0.7, 0.8, 0.68)]
    corners = [(0, 0), (sx, 0), (sx, sy), (0, sy)]
    for k, rgb in enumerate(wall_colours):
        (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % 4]
        wall = builder.material(f"wall {k}", rgb, 0.45, 0.12)
        builder.add_quad(np.array([[x0, y0, 0], [x1, y1, 0], [x1, y1, sz], [x0, y0, sz]]), wall)
    if has_ceiling:
        ceiling = builder.material("ceiling", (0.86, 0.86, 0.84), 0.45, 0.13)
        builder.add_quad(np.array([[0, 0, sz], [0, sy, sz], [sx, sy, sz], [sx, 0, sz]]), ceiling)


def _yaw_matrix(yaw_deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _place(
    rng: np.random.Generator, radius: float, room_size: np.ndarray, placed: list[tuple[np.ndarray, float]]
) -> np.ndarray | None:
    """A floor position for a footprint of this radius that overlaps nothing, or None."""
    low = np.full(2, radius + _WALL_MARGIN)
    high = room_size[:2] - low
    if np.any(high <= low):
        return None
    centre_xy = room_size[:2] / 2
    for _ in range(300):
        xy = rng.uniform(low, high)
        if np.linalg.norm(xy - centre_xy) < CLEAR_RADIUS + radius:
            continue
        if all(np.linalg.norm(xy - p) >= radius + r + _GAP_BETWEEN_OBJECTS for p, r in placed):
            return xy
    return None


def generate_scene(seed: int, num_objects: int | None = None) -> SyntheticScene:
    """A textured room with 4–8 distinct named objects (``num_objects`` to fix the count).

    Deterministic for a seed. Objects never intersect each other or the walls, and a disc of
    radius CLEAR_RADIUS around the room centre stays free.
    """
    rng = np.random.default_rng(seed)
    count = int(rng.integers(4, 9)) if num_objects is None else int(num_objects)
    if not 1 <= count <= len(CATALOGUE):
        raise ValueError(f"num_objects must be in 1..{len(CATALOGUE)}, got {count}")
    room_size = np.array([rng.uniform(6.5, 9.0), rng.uniform(6.0, 8.5), rng.uniform(2.7, 3.2)])
    has_ceiling = bool(rng.random() < 0.5)

    builder = _Builder(rng)
    _add_room(builder, room_size, has_ceiling)

    objects: list[SceneObject] = []
    placed: list[tuple[np.ndarray, float]] = []
    for entry_index in rng.permutation(len(CATALOGUE)):
        if len(objects) == count:
            break
        entry = CATALOGUE[entry_index]
        yaw = float(rng.uniform(0.0, 360.0))
        parts = entry.build(entry.rgb)
        rotation = _yaw_matrix(yaw)
        local = np.concatenate([np.asarray(mesh.vertices) for mesh, _ in parts])
        extent_xy = np.ptp((local @ rotation.T)[:, :2], axis=0)
        radius = float(0.5 * np.hypot(*extent_xy))
        xy = _place(rng, radius, room_size, placed)
        if xy is None:
            continue
        placed.append((xy, radius))
        object_id = len(objects)
        offset = np.array([xy[0], xy[1], 0.0])
        world_vertices = []
        materials_by_colour: dict[tuple[float, float, float], int] = {}
        for mesh, rgb in parts:
            if rgb not in materials_by_colour:
                materials_by_colour[rgb] = builder.material(entry.name, rgb, 0.2, 0.06)
            vertices = np.asarray(mesh.vertices) @ rotation.T + offset
            builder.add(vertices, np.asarray(mesh.triangles), object_id, materials_by_colour[rgb])
            world_vertices.append(vertices)
        world_vertices = np.concatenate(world_vertices)
        low, high = world_vertices.min(axis=0), world_vertices.max(axis=0)
        objects.append(SceneObject(entry.name, (low + high) / 2, high - low, yaw))

    if len(objects) < count:
        raise ValueError(f"seed {seed}: could place only {len(objects)} of {count} objects")
    return builder.scene(seed, objects, room_size, has_ceiling)
