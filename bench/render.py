"""Render speed at 512x512: our numpy splatter on one core against Open3D's offscreen renderer.

    .venv/bin/python -m bench.render [--points 200000 1000000] [--repeats 7] [--open3d-cores all|one]

Our renderer runs pinned to one CPU core with one BLAS thread, without and with its crack-filling
pass (`fill_cracks=True`, on by default in `synthesize_novel_view`), in the same run. Open3D
(Filament; on a machine without a GPU, Vulkan on Mesa's llvmpipe) runs in a child process on the
same cloud and camera, by default with every core this process may use, as the paper ran it. Times
are medians after one warm-up frame; Open3D's first frame (scene upload and pipeline setup) is
reported separately.
"""

from __future__ import annotations

import os

# One BLAS/OpenMP thread for our renderer: set before numpy loads its thread pools.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402

from shared.geometry.rendering import render_point_cloud  # noqa: E402

SIZE = 512
INTRINSIC = np.array([[400.0, 0.0, SIZE / 2], [0.0, 400.0, SIZE / 2], [0.0, 0.0, 1.0]])
POSE = np.hstack([np.eye(3), np.zeros((3, 1))])
SPLATS = {"1 px": (0.5, 1.0), "2x2 px": (1.0, 2.0)}  # name: (our radius, Open3D point_size)


def benchmark_cloud(count: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A room-like cloud in front of the camera: a back wall, a floor and a sphere, random colours."""
    rng = np.random.default_rng(seed)
    wall, floor = count // 3, count // 3
    sphere = count - wall - floor
    wall_points = np.column_stack([rng.uniform(-3, 3, wall), rng.uniform(-2, 1, wall), np.full(wall, 5.0)])
    floor_points = np.column_stack([rng.uniform(-3, 3, floor), np.full(floor, 1.0), rng.uniform(1, 5, floor)])
    directions = rng.normal(size=(sphere, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    sphere_points = 0.6 * directions + [0.3, 0.2, 3.0]
    points = np.concatenate([wall_points, floor_points, sphere_points]).astype(np.float32)
    return points, rng.integers(0, 256, (count, 3), dtype=np.uint8)


def median_ms(render: Callable[[], object], repeats: int) -> tuple[float, float]:
    """(first call, median of the following calls) in milliseconds."""
    timings = []
    for _ in range(repeats + 1):
        start = time.perf_counter()
        render()
        timings.append(1e3 * (time.perf_counter() - start))
    return timings[0], float(np.median(timings[1:]))


def ours_ms(count: int, radius: float, repeats: int, fill_cracks: bool = False) -> float:
    points, colors = benchmark_cloud(count)
    _, median = median_ms(
        lambda: render_point_cloud(
            points, colors, POSE, INTRINSIC, SIZE, SIZE, point_radius_px=radius, fill_cracks=fill_cracks
        ),
        repeats,
    )
    return median


def open3d_worker(count: int, point_size: float, repeats: int) -> dict[str, float]:
    """Runs in the child process: Open3D timings for one configuration."""
    import open3d as o3d  # imported here only: it starts its own threads and a render engine

    rendering = o3d.visualization.rendering
    points, colors = benchmark_cloud(count)
    renderer = rendering.OffscreenRenderer(SIZE, SIZE)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    cloud.colors = o3d.utility.Vector3dVector(colors.astype(np.float64) / 255.0)
    material = rendering.MaterialRecord()
    material.shader = "defaultUnlit"
    material.point_size = point_size
    start = time.perf_counter()
    renderer.scene.add_geometry("cloud", cloud, material)
    upload = 1e3 * (time.perf_counter() - start)
    # The camera goes after the geometry: setup_camera fits near and far planes to the scene bounds.
    camera = o3d.camera.PinholeCameraIntrinsic(
        SIZE, SIZE, INTRINSIC[0, 0], INTRINSIC[1, 1], SIZE / 2, SIZE / 2
    )
    renderer.setup_camera(camera, np.vstack([POSE, [0.0, 0.0, 0.0, 1.0]]))
    renderer.scene.set_background([1.0, 1.0, 1.0, 1.0])
    renderer.scene.view.set_post_processing(False)  # plain colours, like ours: no tone mapping
    first, median = median_ms(renderer.render_to_image, repeats)
    drawn = float(np.mean(np.asarray(renderer.render_to_image()).min(axis=2) < 250))
    return {"upload_ms": upload, "first_ms": first, "median_ms": median, "drawn_fraction": drawn}


def open3d_ms(count: int, point_size: float, repeats: int, cores: set[int]) -> dict[str, float] | str:
    """Open3D timings from a child process, or the reason it could not run."""
    command = [
        sys.executable,
        "-m",
        "bench.render",
        "--open3d-worker",
        str(count),
        str(point_size),
        str(repeats),
    ]
    environment = {key: value for key, value in os.environ.items() if not key.endswith("_NUM_THREADS")}
    try:
        finished = subprocess.run(
            command,
            capture_output=True,
            text=True,
            timeout=300,
            env=environment,
            preexec_fn=lambda: os.sched_setaffinity(0, cores),
        )
    except subprocess.TimeoutExpired:
        return "timed out after 300 s"
    lines = [line for line in finished.stdout.splitlines() if line.startswith("{")]
    if finished.returncode != 0 or not lines:
        tail = (finished.stderr or finished.stdout).strip().splitlines()[-3:]
        return f"exit {finished.returncode}: {' | '.join(tail)}"
    return json.loads(lines[-1])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.render", description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=[200_000, 1_000_000])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--open3d-cores", choices=["all", "one"], default="all")
    parser.add_argument("--skip-open3d", action="store_true")
    parser.add_argument(
        "--open3d-worker", nargs=3, metavar=("COUNT", "POINT_SIZE", "REPEATS"), help=argparse.SUPPRESS
    )
    arguments = parser.parse_args(argv)

    if arguments.open3d_worker:
        count, point_size, repeats = arguments.open3d_worker
        print(json.dumps(open3d_worker(int(count), float(point_size), int(repeats))))
        return

    allowed = sorted(os.sched_getaffinity(0))
    one_core = {allowed[0]}
    open3d_cores = one_core if arguments.open3d_cores == "one" else set(allowed)
    print(f"512x512, medians of {arguments.repeats} frames after one warm-up. Ours: numpy {np.__version__},")
    print(f"pinned to core {allowed[0]}. Open3D: cores {sorted(open3d_cores)} of {os.cpu_count()} here.\n")
    print(
        "| points | splat | ours, 1 core (ms) | ours + crack fill (ms) | Open3D (ms) "
        "| Open3D first frame (ms) | Open3D / ours | Open3D drawn |"
    )
    print("| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for count in arguments.points:
        for name, (radius, point_size) in SPLATS.items():
            os.sched_setaffinity(0, one_core)
            ours = ours_ms(count, radius, arguments.repeats)
            filled = ours_ms(count, radius, arguments.repeats, fill_cracks=True)
            os.sched_setaffinity(0, set(allowed))
            theirs = (
                "skipped"
                if arguments.skip_open3d
                else open3d_ms(count, point_size, arguments.repeats, open3d_cores)
            )
            if isinstance(theirs, dict):
                cells = f"{theirs['median_ms']:.1f} | {theirs['first_ms'] + theirs['upload_ms']:.0f} | "
                cells += f"{theirs['median_ms'] / ours:.1f}x | {100 * theirs['drawn_fraction']:.0f}%"
            else:
                cells = f"n/a | n/a | n/a | n/a ({theirs})"
            print(f"| {count:,} | {name} | {ours:.1f} | {filled:.1f} | {cells} |", flush=True)


if __name__ == "__main__":
    main()
