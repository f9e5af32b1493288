"""A weak-texture ring of calibrated photographs, written in the Middlebury multi-view format.

A dark, smoothly bumped object with faint surface texture stands on a dark background; cameras on
a ring around it (jittered in height, distance and aim) look at it. Everything follows from one
seed, so a ring made with a seed no change was tuned on is a held-out set.

    .venv/bin/python -m shared.synthetic.weak_texture_ring OUT_DIR --seed 11 [--views 48]

writes `OUT_DIR/<name>0001.png ...`, `OUT_DIR/<name>_par.txt` (a count line, then per image:
name, K row-major, R row-major, t; camera-from-world, OpenCV axes, pixels with integer centres)
and `OUT_DIR/<name>_ang.txt` (per image: elevation and azimuth in degrees, then the name), as the
Middlebury templeRing files are laid out.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import open3d as o3d

from shared.synthetic.render import look_at

WIDTH, HEIGHT = 640, 480
OBJECT_RADIUS = 0.06  # metres, about templeRing's scale
_LIGHT = np.array([0.3, -0.5, 0.81]) / np.linalg.norm([0.3, -0.5, 0.81])  # z is up here
_UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class RingView:
    name: str
    intrinsic: np.ndarray  # 3x3
    extrinsic: np.ndarray  # 3x4 camera-from-world
    elevation_deg: float
    azimuth_deg: float


class SmoothNoise:
    """A sum of random plane waves in 3-D: smooth, seeded, defined everywhere on the surface."""

    def __init__(self, rng: np.random.Generator, waves: int, wavelength: float) -> None:
        directions = rng.normal(size=(waves, 3))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        scales = wavelength * rng.uniform(0.5, 2.0, waves)
        self.frequencies = directions * (2 * np.pi / scales)[:, None]
        self.phases = rng.uniform(0, 2 * np.pi, waves)
        self.norm = np.sqrt(waves / 2)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        return np.sin(points @ self.frequencies.T + self.phases).sum(axis=1) / self.norm


def object_mesh(rng: np.random.Generator) -> o3d.t.geometry.TriangleMesh:
    """A bumped, slightly squashed sphere on a low plinth: no sharp edges, few corners to match."""
    sphere = o3d.geometry.TriangleMesh.create_sphere(radius=1.0, resolution=80)
    vertices = np.asarray(sphere.vertices)
    bumps = SmoothNoise(rng, waves=12, wavelength=1.2)
    radius = OBJECT_RADIUS * (1.0 + 0.12 * bumps(vertices))
    stretched = vertices * radius[:, None] * np.array([1.0, rng.uniform(0.7, 0.9), rng.uniform(1.1, 1.4)])
    sphere.vertices = o3d.utility.Vector3dVector(stretched)
    plinth = o3d.geometry.TriangleMesh.create_cylinder(radius=OBJECT_RADIUS * 1.1, height=0.02, resolution=60)
    plinth.translate((0.0, 0.0, stretched[:, 2].min() - 0.006))  # its top just inside the body
    return o3d.t.geometry.TriangleMesh.from_legacy(sphere + plinth)


def ring_cameras(rng: np.random.Generator, views: int, name: str) -> list[RingView]:
    focal = rng.uniform(1350, 1650)
    intrinsic = np.array(
        [[focal, 0.0, WIDTH / 2 + rng.uniform(-15, 15)], [0.0, focal, HEIGHT / 2 + rng.uniform(-15, 15)]]
        + [[0.0, 0.0, 1.0]]
    )
    distance = OBJECT_RADIUS * 2.6 * focal / (0.5 * HEIGHT)  # the object fills about two thirds of the height
    cameras = []
    for index in range(views):
        azimuth = 360.0 * index / views + rng.uniform(-1.0, 1.0)
        elevation = 25.0 + rng.uniform(-3.0, 3.0)
        reach = distance * rng.uniform(0.95, 1.05)
        a, e = np.radians(azimuth), np.radians(elevation)
        eye = reach * np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        target = rng.normal(0.0, OBJECT_RADIUS * 0.05, 3)
        extrinsic = look_at(eye, target, up=_UP)
        cameras.append(RingView(f"{name}{index + 1:04d}.png", intrinsic, extrinsic, elevation, azimuth))
    return cameras


def render(
    scene: o3d.t.geometry.RaycastingScene,
    view: RingView,
    texture: tuple[SmoothNoise, SmoothNoise],
    rng: np.random.Generator,
) -> np.ndarray:
    """A dark, faintly textured, Lambertian object on a near-black background, with sensor noise."""
    u, v = np.meshgrid(np.arange(WIDTH, dtype=np.float64), np.arange(HEIGHT, dtype=np.float64))
    pixels = np.stack([u.ravel(), v.ravel(), np.ones(u.size)], axis=1)
    rotation = view.extrinsic[:, :3]
    origin = -rotation.T @ view.extrinsic[:, 3]
    directions = pixels @ np.linalg.inv(view.intrinsic).T @ rotation
    rays = np.hstack([np.broadcast_to(origin, directions.shape), directions]).astype(np.float32)
    hits = scene.cast_rays(o3d.core.Tensor(rays))
    t_hit = hits["t_hit"].numpy()
    hit = np.isfinite(t_hit)
    points = origin + directions[hit] * t_hit[hit, None]
    normals = hits["primitive_normals"].numpy()[hit].astype(np.float64)
    normals *= -np.sign(np.einsum("ij,ij->i", normals, directions[hit]))[:, None]
    shade = 0.35 + 0.65 * np.clip(normals @ _LIGHT, 0.0, 1.0)
    coarse, fine = texture
    unit = points / OBJECT_RADIUS
    albedo = 0.16 * (1.0 + 0.15 * coarse(unit) + 0.25 * fine(unit))  # dark, faint texture
    grey = np.full(WIDTH * HEIGHT, 0.03)
    grey[hit] = albedo * shade
    tint = np.array([1.0, 0.92, 0.85])  # a warm dark object, like a bronze
    image = grey.reshape(HEIGHT, WIDTH, 1) * tint * 255.0
    image = cv2.GaussianBlur(image, (0, 0), 0.6)  # optics
    image += rng.normal(0.0, 1.2, image.shape)  # sensor noise, in grey levels
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def make_ring(out: Path, seed: int, views: int = 48, name: str = "weakRing") -> list[RingView]:
    rng = np.random.default_rng(seed)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(object_mesh(rng))
    texture = (SmoothNoise(rng, waves=24, wavelength=0.35), SmoothNoise(rng, waves=48, wavelength=0.08))
    cameras = ring_cameras(rng, views, name)
    out.mkdir(parents=True, exist_ok=True)
    for view in cameras:
        rgb = render(scene, view, texture, rng)
        cv2.imwrite(str(out / view.name), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    write_par(out / f"{name}_par.txt", cameras)
    angles = [f"{view.elevation_deg:.6f} {view.azimuth_deg:.6f} {view.name}" for view in cameras]
    (out / f"{name}_ang.txt").write_text("\n".join(angles) + "\n")
    return cameras


def write_par(path: Path, cameras: list[RingView]) -> None:
    lines = [str(len(cameras))]
    for view in cameras:
        numbers = [*view.intrinsic.ravel(), *view.extrinsic[:, :3].ravel(), *view.extrinsic[:, 3]]
        lines.append(view.name + " " + " ".join(f"{value:.12g}" for value in numbers))
    path.write_text("\n".join(lines) + "\n")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--views", type=int, default=48)
    parser.add_argument("--name", default="weakRing")
    args = parser.parse_args(argv)
    make_ring(args.out, args.seed, args.views, args.name)
    print(f"wrote {args.views} views to {args.out}")


if __name__ == "__main__":
    main()
