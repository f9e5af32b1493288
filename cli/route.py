"""`pyspatial route`: a route plan from a start view to a goal through the agent's POST /v1/route."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import typer

from cli.api_keys import agent_key_option
from cli.console import console, fail, service_errors
from cli.images import collect_images
from cli.progress import spinner
from shared.wire.client import AgentClient
from shared.wire.settings import DEFAULT_AGENT_PORT

DEFAULT_AGENT_URL = f"http://127.0.0.1:{DEFAULT_AGENT_PORT}"


def parse_goal(pixel: str | None, world: str | None, camera: str | None) -> dict:
    """The goal of the request from exactly one of the three options."""
    given = [value for value in (pixel, world, camera) if value]
    if len(given) != 1:
        raise fail("give exactly one of --goal-pixel VIEW:U,V, --goal-world X,Y,Z or --goal-camera X,Y,Z")
    try:
        if pixel:
            view, _, coordinates = pixel.partition(":")
            u, v = (float(part) for part in coordinates.split(","))
            return {"pixel": {"view": int(view), "u": u, "v": v}}
        point = [float(part) for part in (world or camera).split(",")]
    except ValueError:
        raise fail(
            "could not read the goal: --goal-pixel is VIEW:U,V (2:320,200); points are X,Y,Z"
        ) from None
    if len(point) != 3:
        raise fail("a goal point is three numbers X,Y,Z")
    return {"point_world": point} if world else {"point_start_camera": point}


def split_depths(arguments: list[Path], depths: list[Path] | None) -> tuple[list[Path], list[Path]]:
    """Photos and depth files apart. A shell glob after --depths (`--depths d*.npy`) gives the option
    its first file and leaves the others among the photos: every .npy there is a depth, in the
    order given (a .npy is never a photo)."""
    photos = [path for path in arguments if path.suffix.lower() != ".npy"]
    named = [*(depths or []), *(path for path in arguments if path.suffix.lower() == ".npy")]
    return photos, [found for path in named for found in _expanded(path)]


def _expanded(path: Path) -> list[Path]:
    """A quoted pattern the shell left alone ('d*.npy'), as the files it matches sorted by name."""
    if path.exists() or not any(mark in str(path) for mark in "*?["):
        return [path]
    return sorted(path.parent.glob(path.name)) or [path]


def _matrix(value, shape: tuple[int, int]) -> bool:
    return np.asarray(value, dtype=object).shape == shape


def per_view_intrinsics(given: dict, num_views: int) -> list:
    """One 3x3 per view from a cameras file: `intrinsics` as one per view, or one shared 3x3 (as
    `intrinsic` or as `intrinsics`), repeated for every view."""
    shared = given.get("intrinsic", given.get("intrinsics"))
    if shared is not None and _matrix(shared, (3, 3)):
        return [shared] * num_views
    listed = given.get("intrinsics")
    if not isinstance(listed, list) or len(listed) != num_views:
        count = len(listed) if isinstance(listed, list) else 0
        raise fail(
            f'--cameras: give one shared 3x3 "intrinsic" or one 3x3 per view in "intrinsics" '
            f"(views 1..{num_views}); found {count}"
        )
    for view, matrix in enumerate(listed, 1):
        if not _matrix(matrix, (3, 3)):
            raise fail(f"--cameras: the intrinsics of view {view} are not a 3x3 matrix")
    return listed


def _read_posed(depths: list[Path], cameras: Path) -> tuple[list[np.ndarray], dict]:
    try:
        given = json.loads(cameras.read_text())
    except (OSError, ValueError) as error:
        raise fail(f"could not read --cameras {cameras}: {error}") from None
    arrays = []
    for view, path in enumerate(depths, 1):
        try:
            arrays.append(np.load(path, allow_pickle=False))
        except (OSError, ValueError) as error:
            raise fail(f"could not read the depth of view {view} ({path}): {error}") from None
    if not isinstance(given, dict):
        raise fail('--cameras is a JSON object {"extrinsics": [3x4 per view], "intrinsic": 3x3}')
    return arrays, given


def posed_inputs(depths: list[Path], cameras: Path | None, num_views: int) -> dict:
    """The posed RGB-D part of the request: per view a depth, a 3x4 pose and a 3x3 intrinsic."""
    if not depths and cameras is None:
        return {}
    if not depths or cameras is None:
        raise fail("--depths and --cameras go together (posed RGB-D)")
    if len(depths) != num_views:
        raise fail(f"{len(depths)} depth file(s) for {num_views} photos: give one .npy per view, in order")
    arrays, given = _read_posed(depths, cameras)
    extrinsics = given.get("extrinsics")
    if not isinstance(extrinsics, list) or len(extrinsics) != num_views:
        raise fail(f'--cameras: "extrinsics" needs one 3x4 camera-from-world per view (views 1..{num_views})')
    for view, pose in enumerate(extrinsics, 1):
        if not (_matrix(pose, (3, 4)) or _matrix(pose, (4, 4))):
            raise fail(f"--cameras: the extrinsic of view {view} is not a 3x4 (or 4x4) matrix")
    cam_from_world = [np.asarray(pose, dtype=float)[:3] for pose in extrinsics]
    return {
        "depths": arrays,
        "extrinsics": np.stack(cam_from_world),
        "intrinsics": per_view_intrinsics(given, num_views),
    }


def _scale_words(plan) -> str:
    words = f"units: {plan.units}, scale from {plan.scale_from or 'unknown'}"
    if plan.floor_residual_m is not None:
        words += f" (floor fit residual {plan.floor_residual_m:.3f} m)"
    if plan.scale_check is not None:
        words += f"; reconstructed camera height / given: {plan.scale_check:.2f}"
    return words


def route(
    photos: list[Path] = typer.Argument(..., help="Image files, or one folder (sorted by name)."),
    start_view: int = typer.Option(1, help="The view (1-based) whose camera stands above the robot."),
    goal_pixel: str | None = typer.Option(None, help="VIEW:U,V, a pixel (column, row) of a view (1-based)."),
    goal_world: str | None = typer.Option(None, help="X,Y,Z in the reconstruction's world frame."),
    goal_camera: str | None = typer.Option(None, help="X,Y,Z in the start camera's frame (OpenCV axes)."),
    depths: list[Path] = typer.Option(
        None,
        help="Per view a .npy z-depth in metres (with --cameras), in view order: repeat the option, or "
        "give several files (--depths d*.npy) or a quoted pattern (--depths 'd*.npy', sorted by name).",
    ),
    cameras: Path | None = typer.Option(
        None,
        help='JSON {"extrinsics": [3x4 camera-from-world per view], "intrinsic": one shared 3x3} '
        '(or "intrinsics": one 3x3 per view).',
    ),
    radius: float = typer.Option(0.25, help="The robot's radius, metres."),
    height: float = typer.Option(0.5, help="The top of the robot's body above the floor, metres."),
    floor_clearance: float = typer.Option(0.05, help="The bottom of its body: lower things are driven over."),
    camera_height: float | None = typer.Option(
        None, help="The robot's camera above the floor, metres: photos alone then give metres."
    ),
    backbone: str | None = typer.Option(None, help="Reconstruction backbone (posed-rgbd with depths)."),
    out: Path | None = typer.Option(
        None, help="Where to write the plan.", show_default="pyspatial-out/route/<scene id>.json"
    ),
    agent_url: str = typer.Option(DEFAULT_AGENT_URL, envvar="PYSPATIAL_AGENT_URL", help="Agent service."),
    timeout: float = typer.Option(900.0, help="Seconds to wait for the plan."),
    api_key: str | None = agent_key_option(),
) -> None:
    """Plan turns and forward moves from the floor below a view's camera to a goal, avoiding obstacles."""
    goal = parse_goal(goal_pixel, goal_world, goal_camera)
    images, depth_files = split_depths(photos, depths)
    try:
        paths = collect_images(images)
    except ValueError as error:
        raise fail(str(error)) from None
    posed = posed_inputs(depth_files, cameras, len(paths))
    robot = {"radius": radius, "height": height, "floor_clearance": floor_clearance}
    if camera_height is not None:
        if not camera_height > 0:
            raise fail(f"--camera-height must be a positive number of metres, got {camera_height}")
        robot["camera_height_m"] = camera_height
    with service_errors(), AgentClient(agent_url, timeout=timeout, api_key=api_key) as client:
        with spinner(f"planning a route over {len(paths)} photos"):
            plan = client.route(
                goal, images=paths, start_view=start_view, robot=robot, backbone=backbone, **posed
            )
    target = out or Path("pyspatial-out") / "route" / f"{plan.scene_id}.json"
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(plan.model_dump_json(indent=2))
    if plan.reachable:
        unit = "m" if plan.units == "metres" else "scene units"
        for number, sentence in enumerate(plan.sentences, 1):
            console.print(f"{number}. {sentence}")
        console.print(
            f"length {plan.length:.2f} {unit} (straight line {plan.straight_line:.2f}), "
            f"smallest clearance {plan.clearance:.2f} {unit}; turns are {plan.turn_convention}"
        )
        if plan.unseen_m:
            console.print(f"[yellow]{plan.unseen_m:.2f} {unit} cross floor no photo shows[/]")
    else:
        console.print(f"[red]no route:[/] {plan.reason}")
        if plan.look_next is not None:
            console.print("to find the way, take a photo from here (then plan again from it):")
            for number, sentence in enumerate(plan.look_next.sentences, 1):
                console.print(f"{number}. {sentence}")
    console.print(_scale_words(plan))
    for warning in plan.warnings:
        console.print(f"[yellow]warning:[/] {warning}")
    console.print(f"plan written to {target}")
