"""Bundle adjustment of the sparse model with COLMAP's Ceres-based adjuster (pycolmap).

Refines every registered pose, every point and the focal length shared by the views whose camera
is unknown, minimizing reprojection error under a Cauchy loss (a wrong match costs little once
it is a few pixels off). Views with given intrinsics keep them fixed. Views of one image size
whose camera is unknown share one pinhole (`SIMPLE_PINHOLE`: one focal, fixed principal point at
the image centre): photos of one scene are usually from one camera, and a focal shared by all
views is far better determined than one per view.

The gauge (where the world is and how big) is fixed by the first camera's pose and the distance
to the second, as COLMAP does (`TWO_CAMS_FROM_WORLD`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .colmap_import import pycolmap

LOSS_SCALE_PX = 1.0  # Cauchy scale: residuals well beyond this count roughly logarithmically
MAX_ITERATIONS = 100


@dataclass(frozen=True)
class AdjustedModel:
    extrinsics: dict[int, np.ndarray]  # view -> 3x4 camera-from-world
    intrinsics: dict[int, np.ndarray]  # view -> 3x3, working-image pixels
    points: np.ndarray  # (P, 3), same order as the input tracks
    usable: bool  # Ceres reports a usable solution
    converged: bool = True  # Ceres stopped on a tolerance (not on the iteration cap or a failure)


def bundle_adjust(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    intrinsics: list[np.ndarray],
    free_focal: list[bool],
    extrinsics: dict[int, np.ndarray],
    points: np.ndarray,
    tracks: list[dict[int, int]],
    refine_focal: bool = True,
    max_iterations: int = MAX_ITERATIONS,
) -> AdjustedModel:
    """Adjust poses, points and (where `free_focal[view]` and `refine_focal`) the shared focal.

    keypoints, image_sizes (width, height) and intrinsics are per view, in working-image pixels;
    extrinsics are 3x4 camera-from-world [R|t] (OpenCV axes), as pycolmap's cam_from_world.
    """
    reconstruction = pycolmap.Reconstruction()
    camera_of_view = _add_cameras(reconstruction, image_sizes, intrinsics, free_focal, extrinsics)
    for view in sorted(extrinsics):
        image = pycolmap.Image(
            name=str(view),
            keypoints=np.asarray(keypoints[view], dtype=np.float64).reshape(-1, 2),
            camera_id=camera_of_view[view],
            image_id=view + 1,
        )
        reconstruction.add_image_with_trivial_frame(image, pycolmap.Rigid3d(extrinsics[view]))
    point_ids = []
    for point, track in zip(points, tracks, strict=True):
        colmap_track = pycolmap.Track()
        for view, keypoint in track.items():
            colmap_track.add_element(view + 1, keypoint)
        point_ids.append(reconstruction.add_point3D(np.asarray(point, dtype=np.float64), colmap_track))

    config = pycolmap.BundleAdjustmentConfig()
    for view in sorted(extrinsics):
        config.add_image(view + 1)
    for view, camera_id in camera_of_view.items():
        if not free_focal[view]:
            config.set_constant_cam_intrinsics(camera_id)
    config.fix_gauge(pycolmap.BundleAdjustmentGauge.TWO_CAMS_FROM_WORLD)
    options = _adjuster_options(refine_focal, max_iterations)
    adjuster = pycolmap.create_default_bundle_adjuster(options, config, reconstruction)
    summary = adjuster.solve()

    adjusted_extrinsics = {
        view: np.asarray(reconstruction.image(view + 1).cam_from_world().matrix(), dtype=np.float64)
        for view in extrinsics
    }
    adjusted_intrinsics = {
        view: np.asarray(reconstruction.camera(camera_of_view[view]).calibration_matrix(), dtype=np.float64)
        for view in extrinsics
    }
    adjusted_points = np.array([reconstruction.point3D(pid).xyz for pid in point_ids]).reshape(-1, 3)
    return AdjustedModel(
        adjusted_extrinsics,
        adjusted_intrinsics,
        adjusted_points,
        bool(summary.is_solution_usable()),
        summary.termination_type == pycolmap.BundleAdjustmentTerminationType.CONVERGENCE,
    )


def _add_cameras(
    reconstruction: pycolmap.Reconstruction,
    image_sizes: list[tuple[int, int]],
    intrinsics: list[np.ndarray],
    free_focal: list[bool],
    extrinsics: dict[int, np.ndarray],
) -> dict[int, int]:
    """One SIMPLE_PINHOLE camera per view, except that views of unknown focal and the same image
    size share one camera (so they share the one focal being refined). Returns view -> camera id."""
    camera_of_view: dict[int, int] = {}
    shared_cameras: dict[tuple[int, int], int] = {}
    for view in sorted(extrinsics):
        width, height = image_sizes[view]
        intrinsic = intrinsics[view]
        key = (width, height)
        if free_focal[view] and key in shared_cameras:
            camera_of_view[view] = shared_cameras[key]
            continue
        camera_id = len(camera_of_view) + 1 + len(shared_cameras)
        focal = float(np.sqrt(intrinsic[0, 0] * intrinsic[1, 1]))
        camera = pycolmap.Camera(
            model="SIMPLE_PINHOLE",
            width=width,
            height=height,
            params=[focal, intrinsic[0, 2], intrinsic[1, 2]],
            camera_id=camera_id,
        )
        reconstruction.add_camera_with_trivial_rig(camera)
        camera_of_view[view] = camera_id
        if free_focal[view]:
            shared_cameras[key] = camera_id
    return camera_of_view


def _adjuster_options(refine_focal: bool, max_iterations: int) -> pycolmap.BundleAdjustmentOptions:
    options = pycolmap.BundleAdjustmentOptions()
    options.refine_focal_length = refine_focal
    options.refine_principal_point = False
    options.refine_extra_params = False
    options.print_summary = False
    options.ceres.loss_function_type = pycolmap.LossFunctionType.CAUCHY
    options.ceres.loss_function_scale = LOSS_SCALE_PX
    options.ceres.solver_options.max_num_iterations = max_iterations
    options.ceres.solver_options.num_threads = 1
    # Stop once a step improves the cost by less than a millionth: sub-pixel poses are long
    # settled by then, and the default (0) keeps iterating to the cap.
    options.ceres.solver_options.function_tolerance = 1e-6
    return options


def robust_cost(
    keypoints: list[np.ndarray],
    intrinsics: dict[int, np.ndarray],
    extrinsics: dict[int, np.ndarray],
    points: np.ndarray,
    tracks: list[dict[int, int]],
) -> float:
    """The Cauchy cost adjustment minimizes, summed over every observation of a placed view."""
    return float(np.sum(track_costs(keypoints, intrinsics, extrinsics, points, tracks)))


def track_costs(
    keypoints: list[np.ndarray],
    intrinsics: dict[int, np.ndarray],
    extrinsics: dict[int, np.ndarray],
    points: np.ndarray,
    tracks: list[dict[int, int]],
) -> np.ndarray:
    """robust_cost per track: (T,), each track's observations in the placed views summed."""
    costs = np.zeros(len(tracks))
    for view, extrinsic in extrinsics.items():
        ids = [point for point, track in enumerate(tracks) if view in track]
        if ids:
            costs[ids] += _observation_costs(
                keypoints[view], intrinsics[view], extrinsic, points, tracks, ids, view
            )
    return costs


def _observation_costs(
    view_keypoints: np.ndarray,
    intrinsic: np.ndarray,
    extrinsic: np.ndarray,
    points: np.ndarray,
    tracks: list[dict[int, int]],
    ids: list[int],
    view: int,
) -> np.ndarray:
    """Cauchy cost of each listed point's observation in `view` (3x4 camera-from-world extrinsic)."""
    observed = view_keypoints[[tracks[point][view] for point in ids]]
    camera = points[ids] @ extrinsic[:, :3].T + extrinsic[:, 3]
    depth = np.where(np.abs(camera[:, 2]) < 1e-12, 1e-12, camera[:, 2])
    predicted = camera[:, :2] / depth[:, None] * np.array([intrinsic[0, 0], intrinsic[1, 1]])
    predicted += np.array([intrinsic[0, 2], intrinsic[1, 2]])
    squared = np.sum((predicted - observed) ** 2, axis=1) / LOSS_SCALE_PX**2
    return np.log1p(squared)
