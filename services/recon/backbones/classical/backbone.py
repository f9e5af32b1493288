"""`ClassicalBackbone`: weight-free multi-view reconstruction with OpenCV, the embedded default.

Pipeline: downscale (speed) -> SIFT features -> pairwise matches -> per pair an essential-matrix
or pure-rotation pose -> incremental registration (PnP, else chained pairwise poses) with
triangulation and refinement -> densified, cross-checked coloured cloud.

Conventions of the result (docs/ARCHITECTURE.md):
- Intrinsics are guessed (unknown cameras): focal from `fov_deg` horizontal field of view,
  principal point at the image centre, in ORIGINAL image pixels.
- World frame = camera frame of the first registered view (view 0 unless it could not be placed),
  whose extrinsic is therefore the identity.
- Scale: the median distance of the cloud's points from that first camera is 1. Monocular
  reconstruction has no metric scale; this makes scenes comparable whatever the baseline.
- Views that only rotate about one centre (turning in place) have no baseline, so depth is
  undefined: poses are still rotations, and the cloud is the colour of a pixel grid (every 4th
  working pixel) at ray length 1: a unit sphere around the camera, consistent with the scale
  rule. A warning says so, and `depths` is None.
- An unplaced view has `registered[i] = False`, a warning naming it, and an all-NaN extrinsic so
  that nobody mistakes it for a pose.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from shared.reconstruction import Reconstruction

from ..base import Backbone, BackboneError
from .densify import ViewSamples, densify, grid_size, unit_sphere_cloud
from .features import ViewFeatures, detect_features, match_features
from .geometry import project
from .incremental import IncrementalMapper, SparseModel
from .intrinsics import guess_intrinsics, intrinsics_after_resize, intrinsics_before_resize
from .two_view import TwoViewGeometry, estimate_two_view

MIN_FEATURES = 30  # fewer keypoints than this: the image has no usable texture


@dataclass(frozen=True)
class _PreparedView:
    image: np.ndarray  # working image, uint8 RGB
    original_size: tuple[int, int]  # (width, height)
    scale: float  # working / original
    intrinsic: np.ndarray  # working-image pixels
    features: ViewFeatures


class ClassicalBackbone(Backbone):
    name = "classical"
    version = "2"
    accepts_intrinsics = True

    def __init__(
        self,
        fov_deg: float = 60.0,
        max_features: int = 4000,
        max_image_side: int = 1024,
        densify: bool = True,
        detector: str = "sift",
    ) -> None:
        if not 1.0 < fov_deg < 179.0:
            raise BackboneError(f"fov_deg must be between 1 and 179 degrees, got {fov_deg}")
        if max_features < 100 or max_image_side < 64:
            raise BackboneError("max_features must be >= 100 and max_image_side >= 64")
        if detector not in ("sift", "orb"):
            raise BackboneError(f"detector must be 'sift' or 'orb', got {detector!r}")
        self.fov_deg = fov_deg
        self.max_features = max_features
        self.max_image_side = max_image_side
        self.densify = densify
        self.detector = detector

    def reconstruct(self, images: Sequence[np.ndarray], **options: Any) -> Reconstruction:
        fov_deg = float(options.pop("fov_deg", self.fov_deg))
        use_densify = bool(options.pop("densify", self.densify))
        given = list(options.pop("intrinsics", None) or [None] * len(images))
        given_sources = list(options.pop("intrinsics_sources", None) or [None] * len(images))
        if len(given) != len(images) or len(given_sources) != len(images):
            raise BackboneError(f"intrinsics and intrinsics_sources need one entry per image ({len(images)})")
        if options:
            raise BackboneError(f"unknown options for the classical backbone: {', '.join(sorted(options))}")
        if len(images) < 2:
            raise BackboneError(f"the classical backbone needs at least 2 images, got {len(images)}")
        views = [self._prepare(index, image, fov_deg, given[index]) for index, image in enumerate(images)]
        warnings: list[str] = []
        textured = [index for index, view in enumerate(views) if len(view.features) >= MIN_FEATURES]
        if len(textured) < 2:
            raise BackboneError(
                f"only {len(textured)} of {len(views)} images have enough texture to detect features "
                f"(at least {MIN_FEATURES} keypoints needed in two images)"
            )
        pairs = self._relate_pairs(views, textured)
        if not pairs:
            raise BackboneError(
                f"no two of the {len(views)} images share enough matching features to be related"
            )
        model = IncrementalMapper(
            [view.features.keypoints for view in views], [view.intrinsic for view in views], pairs
        ).run()
        warnings.extend(model.warnings)
        if len(model.extrinsics) < 2:
            raise BackboneError("could not place two views relative to each other")
        for index in range(len(views)):
            if index not in model.extrinsics:
                reason = (
                    "too little texture"
                    if index not in textured
                    else "too few reliable matches to placed views"
                )
                warnings.append(f"view {index} could not be registered ({reason}); its extrinsic is NaN")
        reconstruction = self._assemble(views, model, use_densify, warnings)
        reconstruction.intrinsics_source = [
            (source or "given") if intrinsic is not None else "prior"
            for intrinsic, source in zip(given, given_sources, strict=True)
        ]
        return reconstruction

    # ---- steps ----------------------------------------------------------------------------

    def _prepare(
        self, index: int, image: np.ndarray, fov_deg: float, given: np.ndarray | None = None
    ) -> _PreparedView:
        image = np.asarray(image)
        if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise BackboneError(f"image {index} must be uint8 RGB (H, W, 3), got {image.dtype} {image.shape}")
        height, width = image.shape[:2]
        if min(height, width) < 16:
            raise BackboneError(f"image {index} is too small ({width}x{height})")
        scale = min(1.0, self.max_image_side / max(width, height))
        working = (
            image
            if scale == 1.0
            else cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        )
        # cv2.resize rounds the size; use the exact ratio so pixel maps stay consistent.
        scale = working.shape[1] / width
        gray = cv2.cvtColor(working, cv2.COLOR_RGB2GRAY)
        known = guess_intrinsics(width, height, fov_deg) if given is None else np.asarray(given, np.float64)
        intrinsic = intrinsics_after_resize(known, scale)
        features = detect_features(gray, self.max_features, self.detector)
        return _PreparedView(working, (width, height), scale, intrinsic, features)

    @staticmethod
    def _relate_pairs(
        views: list[_PreparedView], textured: list[int]
    ) -> dict[tuple[int, int], TwoViewGeometry]:
        pairs = {}
        for position, first in enumerate(textured):
            for second in textured[position + 1 :]:
                matches = match_features(views[first].features, views[second].features)
                geometry = estimate_two_view(
                    views[first].features.keypoints,
                    views[second].features.keypoints,
                    views[first].intrinsic,
                    views[second].intrinsic,
                    matches,
                )
                if geometry is not None:
                    pairs[(first, second)] = geometry
        return pairs

    def _assemble(
        self, views: list[_PreparedView], model: SparseModel, use_densify: bool, warnings: list[str]
    ) -> Reconstruction:
        reference = min(model.extrinsics)
        extrinsics = _in_reference_frame(model.extrinsics, reference)
        sparse_points = _to_reference(model.points, model.extrinsics[reference])
        samples = [
            _view_samples(view_index, views[view_index], extrinsics[view_index], model, sparse_points)
            for view_index in sorted(extrinsics)
        ]
        depth_maps: dict[int, np.ndarray] | None = None
        if model.pure_rotation:
            warnings.append(
                "the views only rotate about one point: depth is undefined, so the cloud lies on a unit "
                "sphere around the camera"
            )
            points, colors = unit_sphere_cloud(samples)
        else:
            points, colors = sparse_points, _sparse_colors(views, model)
            if use_densify:
                dense = densify(samples)
                points = np.concatenate([points, dense.points])
                colors = np.concatenate([colors, dense.colors])
                depth_maps = dense.depth_maps
            scale = _scale_to_unit_median_distance(points)
            points = points * scale
            extrinsics = {
                view: np.concatenate([e[:, :3], e[:, 3:] * scale], axis=1) for view, e in extrinsics.items()
            }
            if depth_maps is not None:
                depth_maps = {view: depth * np.float32(scale) for view, depth in depth_maps.items()}
        return self._reconstruction(views, extrinsics, points, colors, depth_maps, warnings)

    def _reconstruction(
        self,
        views: list[_PreparedView],
        extrinsics: dict[int, np.ndarray],
        points: np.ndarray,
        colors: np.ndarray,
        depth_maps: dict[int, np.ndarray] | None,
        warnings: list[str],
    ) -> Reconstruction:
        count = len(views)
        all_extrinsics = np.full((count, 3, 4), np.nan)
        for view, extrinsic in extrinsics.items():
            all_extrinsics[view] = extrinsic
        depths = None
        if depth_maps is not None:
            depths = [
                depth_maps.get(index, np.zeros(grid_size(view.original_size, view.scale)[::-1], np.float32))
                for index, view in enumerate(views)
            ]
        return Reconstruction(
            points=points,
            colors=colors,
            extrinsics=all_extrinsics,
            intrinsics=np.array([intrinsics_before_resize(view.intrinsic, view.scale) for view in views]),
            image_sizes=np.array([view.original_size for view in views]),
            registered=np.array([index in extrinsics for index in range(count)]),
            backbone=self.name,
            backbone_version=self.version,
            depths=depths,
            warnings=warnings,
        )


def _in_reference_frame(extrinsics: dict[int, np.ndarray], reference: int) -> dict[int, np.ndarray]:
    """Re-express poses so the reference camera is the world frame (identity extrinsic)."""
    rotation_ref, translation_ref = extrinsics[reference][:, :3], extrinsics[reference][:, 3]
    result = {}
    for view, extrinsic in extrinsics.items():
        rotation = extrinsic[:, :3] @ rotation_ref.T
        result[view] = np.concatenate(
            [rotation, (extrinsic[:, 3] - rotation @ translation_ref)[:, None]], axis=1
        )
    result[reference] = np.concatenate([np.eye(3), np.zeros((3, 1))], axis=1)
    return result


def _to_reference(points: np.ndarray, reference_extrinsic: np.ndarray) -> np.ndarray:
    return points @ reference_extrinsic[:, :3].T + reference_extrinsic[:, 3]


def _scale_to_unit_median_distance(points: np.ndarray) -> float:
    if len(points) == 0:
        return 1.0
    median = float(np.median(np.linalg.norm(points, axis=1)))
    return 1.0 / median if median > 1e-12 else 1.0


def _view_samples(
    index: int, view: _PreparedView, extrinsic: np.ndarray, model: SparseModel, points: np.ndarray
) -> ViewSamples:
    """The view's triangulated keypoints with their depths, for densification."""
    seen = [(point, track[index]) for point, track in enumerate(model.tracks) if index in track]
    pixels = view.features.keypoints[[keypoint for _, keypoint in seen]] if seen else np.zeros((0, 2))
    world = points[[point for point, _ in seen]] if seen else np.zeros((0, 3))
    _, depths = project(world, extrinsic, view.intrinsic)
    ahead = depths > 0
    return ViewSamples(
        index,
        extrinsic,
        view.intrinsic,
        view.image,
        view.original_size,
        view.scale,
        pixels[ahead],
        depths[ahead],
    )


def _sparse_colors(views: list[_PreparedView], model: SparseModel) -> np.ndarray:
    """Each sparse point takes the colour of its keypoint in the first view that sees it."""
    colors = np.zeros((len(model.tracks), 3), np.uint8)
    for point, track in enumerate(model.tracks):
        view = min(track)
        u, v = views[view].features.keypoints[track[view]]
        height, width = views[view].image.shape[:2]
        colors[point] = views[view].image[min(int(round(v)), height - 1), min(int(round(u)), width - 1)]
    return colors
