"""`POST /v1/route`'s work: the scene uploaded (or looked up) and reconstructed, the goal placed, a plan.

The agent downloads the reconstruction from recon once per request and plans with
``shared.navigation`` (pure numpy, a fraction of a second). View numbers are 1-based here, as on
the page, in the CLI and in the program API; ``shared.navigation`` takes indices (0-based) and its
messages name views from 1. Goals the planner cannot start from are the client's 422 (a pixel
outside the image, on nothing reconstructed, inside an obstacle); a goal no route reaches is a
200 with ``reachable: false`` and the reason.
"""

from __future__ import annotations

import numpy as np

from services.agent.errors import SolveError
from shared.geometry.reconstruction import Reconstruction
from shared.navigation import Robot, locate, plan_route
from shared.navigation.route import DEFAULT_UNSEEN_COST
from shared.wire.client import ReconClient
from shared.wire.schemas import RouteGoal, RouteRequest, RouteResponse


def _goal_point(recon: Reconstruction, goal: RouteGoal, start: int) -> np.ndarray:
    given = [
        name for name in ("pixel", "point_world", "point_start_camera") if getattr(goal, name) is not None
    ]
    if len(given) != 1:
        raise SolveError(422, "give the goal as exactly one of pixel, point_world or point_start_camera")
    if goal.point_world is not None:
        return np.asarray(goal.point_world, np.float64)
    if goal.point_start_camera is not None:
        cam_from_world = recon.extrinsics[start]
        rotation, translation = cam_from_world[:, :3], cam_from_world[:, 3]
        return rotation.T @ (np.asarray(goal.point_start_camera, np.float64) - translation)
    pixel = goal.pixel
    view = pixel.view - 1
    if view >= recon.num_views:
        raise SolveError(
            422, f"goal pixel: view {pixel.view} does not exist (the scene has {recon.num_views})"
        )
    width, height = (int(n) for n in recon.image_sizes[view])
    if not (0 <= pixel.u <= width - 1 and 0 <= pixel.v <= height - 1):
        raise SolveError(
            422,
            f"goal pixel ({pixel.u:g}, {pixel.v:g}) is outside view {pixel.view}'s image of {width}x{height}",
        )
    found = locate(recon, view, pixel.u, pixel.v)
    if found.point is None:
        raise SolveError(422, f"goal pixel: nothing is reconstructed there ({found.reason})")
    return found.point


def _response(plan, scene_id: str, backbone: str, located: np.ndarray | None) -> RouteResponse:
    body = plan.to_dict()
    return RouteResponse(
        scene_id=scene_id,
        backbone=backbone,
        reachable=plan.reachable,
        reason=plan.reason,
        refusal=plan.refusal,
        steps=plan.steps,
        sentences=plan.sentences,
        path_world=body["path_world"],
        path_start_camera=body["path_start_camera"],
        clearance=plan.clearance,
        length=plan.length,
        straight_line=plan.straight_line_distance,
        units=plan.units,
        metres_per_unit=plan.metres_per_unit,
        start_world=body["start_world"],
        goal_world=body["goal_world"],
        up=body["up"],
        warnings=plan.warnings,
        scale_from=plan.scale_from,
        floor_residual_m=plan.floor_residual_m,
        scale_check=plan.scale_check,
        unseen_m=plan.unseen_m,
        unseen_stretches=plan.unseen_stretches,
        narrowest_passage_m=plan.narrowest_passage_m,
        look_next=plan.look_next,
        goal_located=None if located is None else np.round(located, 4).tolist(),
    )


def plan_for_scene(
    recon: Reconstruction,
    scene_id: str,
    backbone: str,
    body: RouteRequest,
    unseen_cost: float = DEFAULT_UNSEEN_COST,
) -> RouteResponse:
    """The plan on one reconstruction; a SolveError (422) for a bad start view or goal."""
    start = body.start_view - 1
    if start >= recon.num_views or not recon.registered[start]:
        raise SolveError(422, f"start view {body.start_view} does not exist or has no pose")
    goal = _goal_point(recon, body.goal, start)
    robot = Robot(
        radius=body.robot.radius,
        height=body.robot.height,
        floor_clearance=body.robot.floor_clearance,
        camera_height=body.robot.camera_height_m,
    )
    try:
        plan = plan_route(recon, start, goal, robot=robot, unseen_cost=unseen_cost)
    except ValueError as error:
        raise SolveError(422, str(error)) from error
    if plan.refusal == "goal_in_obstacle":
        raise SolveError(422, f"the goal is inside an obstacle: {plan.reason}")
    return _response(plan, scene_id, backbone, goal if body.goal.pixel is not None else None)


def route(
    body: RouteRequest,
    images: list[bytes],
    depths: list[np.ndarray],
    client: ReconClient,
    unseen_cost: float = DEFAULT_UNSEEN_COST,
) -> RouteResponse:
    """Upload (or look up) the scene, reconstruct it, download it and plan."""
    if images and body.scene_id:
        raise SolveError(422, "send either images or a scene_id, not both")
    if depths and not images:
        raise SolveError(422, "depths come with the images they belong to")
    if images:
        scene_id = client.upload_scene(
            images, depths=depths or None, extrinsics=body.extrinsics, intrinsics=body.intrinsics
        ).scene_id
    elif body.scene_id:
        scene_id = body.scene_id
    else:
        raise SolveError(422, "send images (multipart 'images' or JSON base64) or an existing scene_id")
    backbone = body.backbone or ("posed-rgbd" if depths else None)
    summary = client.reconstruct(scene_id, backbone)
    recon = client.reconstruction(scene_id, summary.backbone)
    return plan_for_scene(recon, scene_id, summary.backbone, body, unseen_cost)
