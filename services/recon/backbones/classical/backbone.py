"""`ClassicalBackbone`: weight-free multi-view reconstruction with OpenCV, the embedded default.

Pipeline: downscale (speed) -> SIFT features -> pairwise matches -> per pair an essential-matrix
or pure-rotation pose -> incremental registration (PnP, else chained pairwise poses) with
triangulation and refinement -> bundle adjustment with self-calibration of the unknown focal
(solve.py) -> verification: views the data does not support are unregistered with the reason
(verification.py) -> densified, cross-checked coloured cloud.

Conventions of the result (docs/ARCHITECTURE.md):
- Intrinsics, in ORIGINAL image pixels: given ones (uploaded or EXIF, `intrinsics=`) are used as
  they are; views without share a focal estimated from the data ("self-calibrated") when the data
  determines it better than the prior, else the `fov_deg` horizontal field-of-view prior
  ("prior"); principal point at the image centre. Each view's source is in `intrinsics_source`.
- Per-view confidence (inliers, their spread, reprojection error after adjustment, share of
  points in front) and per-pair confidence (shared points, error, triangulation angle).
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

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np

from shared.geometry.reconstruction import PairConfidence, Reconstruction, ViewConfidence

from ..base import Backbone, BackboneError
from .blas_threads import use_one_blas_thread
from .densify import ViewSamples, densify, grid_size, unit_sphere_cloud
from .features import ViewFeatures, detect_features, is_dark, match_features, with_tilts
from .geometry import project
from .incremental import SparseModel
from .intrinsics import guess_intrinsics, intrinsics_after_resize, intrinsics_before_resize
from .solve import Solution, solve_with_self_calibration
from .verification import MIN_VIEW_INLIERS

MIN_FEATURES = 30  # fewer keypoints than this: the image has no usable texture
# A dark photo's simulated tilts (features.py) are detected only when the view needs them: when
# none of its pairs has this many plain matches. The tilts add matches where plain SIFT loses the
# foreshortened surfaces; a view already tied to another by twice the inliers a placed view needs
# (room for half of them to be outliers) gains no placement from them, and on a brightened photo
# they are a third of the detection time (synthetic dark rings, tuning seeds: every view tied by
# 190-800 plain matches, the same views placed without the tilts, 28% faster).
WELL_TIED_MATCHES = 2 * MIN_VIEW_INLIERS


@dataclass(frozen=True)
class _PreparedView:
    image: np.ndarray  # working image, uint8 RGB
    original_size: tuple[int, int]  # (width, height)
    scale: float  # working / original
    intrinsic: np.ndarray  # working-image pixels
    features: ViewFeatures
    gray: np.ndarray | None = None  # set while the view's tilts are not detected yet (a dark photo)


class ClassicalBackbone(Backbone):
    name = "classical"
    version = "6"  # 6: rotation-only models verified, pair uncertainty flags; 5: focal hypotheses
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

    def reconstruct(
        self,
        images: Sequence[np.ndarray],
        intrinsics: Sequence[np.ndarray | None] | None = None,
        intrinsics_sources: Sequence[str | None] | None = None,
        **options: Any,
    ) -> Reconstruction:
        """`intrinsics`: per view a 3x3 in the original image's pixels, or None (unknown);
        `intrinsics_sources`: per view where a given one came from ("uploaded" or "exif")."""
        fov_deg = float(options.pop("fov_deg", self.fov_deg))
        use_densify = bool(options.pop("densify", self.densify))
        if options:
            raise BackboneError(f"unknown options for the classical backbone: {', '.join(sorted(options))}")
        if len(images) < 2:
            raise BackboneError(f"the classical backbone needs at least 2 images, got {len(images)}")
        given, sources = _given_intrinsics(intrinsics, intrinsics_sources, len(images))
        use_one_blas_thread()  # the threads below parallelize instead (blas_threads.py)
        # Same images, same answer: RANSAC draws from OpenCV's (per-thread) generator.
        cv2.setRNGSeed(0)
        # Detection and matching run in OpenCV and BLAS, which release the GIL: one thread per
        # image or pair keeps every core busy (the results do not depend on the order).
        with ThreadPoolExecutor(max_workers=_worker_count(len(images))) as pool:
            views = list(
                pool.map(
                    lambda index: self._prepare(index, images[index], fov_deg, given[index]),
                    range(len(images)),
                )
            )
        warnings: list[str] = []
        textured = [index for index, view in enumerate(views) if len(view.features) >= MIN_FEATURES]
        if len(textured) < 2:
            raise BackboneError(
                f"only {len(textured)} of {len(views)} images have enough texture to detect features "
                f"(at least {MIN_FEATURES} keypoints needed in two images)"
            )
        matches = _match_pairs([view.features for view in views], textured)
        views, matches = self._tilts_where_needed(views, textured, matches)
        free = [intrinsic is None for intrinsic in given]
        solution = solve_with_self_calibration(
            [view.features.keypoints for view in views],
            [(view.image.shape[1], view.image.shape[0]) for view in views],
            [view.intrinsic for view in views],
            free,
            matches,
        )
        warnings.extend(solution.warnings)
        views = [replace(view, intrinsic=solution.intrinsics[index]) for index, view in enumerate(views)]
        for index, intrinsic in enumerate(given):
            if intrinsic is None:
                sources[index] = solution.free_focal_source
        confidence, pair_confidence = _confidence_in_image_pixels(views, solution, textured, warnings)
        recon = self._assemble(views, solution.model, use_densify, warnings)
        recon.intrinsics_source = sources
        recon.view_confidence = confidence
        recon.pair_confidence = pair_confidence
        recon.focal_hypotheses = solution.focal_hypotheses
        return recon

    # ---- steps ----------------------------------------------------------------------------

    def _prepare(
        self, index: int, image: np.ndarray, fov_deg: float, given: np.ndarray | None
    ) -> _PreparedView:
        image = np.asarray(image)
        if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise BackboneError(
                f"image {index + 1} must be uint8 RGB (H, W, 3), got {image.dtype} {image.shape}"
            )
        height, width = image.shape[:2]
        if min(height, width) < 16:
            raise BackboneError(f"image {index + 1} is too small ({width}x{height})")
        scale = min(1.0, self.max_image_side / max(width, height))
        working = (
            image
            if scale == 1.0
            else cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        )
        # cv2.resize rounds the size; use the exact ratio so pixel maps stay consistent.
        scale = working.shape[1] / width
        gray = cv2.cvtColor(working, cv2.COLOR_RGB2GRAY)
        original = guess_intrinsics(width, height, fov_deg) if given is None else given
        intrinsic = intrinsics_after_resize(original, scale)
        if is_dark(gray):
            features = detect_features(gray, self.max_features, self.detector, tilts=())
            return _PreparedView(working, (width, height), scale, intrinsic, features, gray)
        features = detect_features(gray, self.max_features, self.detector)
        return _PreparedView(working, (width, height), scale, intrinsic, features)

    def _tilts_where_needed(
        self, views: list[_PreparedView], textured: list[int], matches: dict[tuple[int, int], np.ndarray]
    ) -> tuple[list[_PreparedView], dict[tuple[int, int], np.ndarray]]:
        """Views whose tilts were put off (dark photos) and that no pair ties well (WELL_TIED_MATCHES)
        get them now, and their pairs are matched again; the other views' tilts are dropped."""
        best = dict.fromkeys(textured, 0)
        for (first, second), found in matches.items():
            best[first] = max(best[first], len(found))
            best[second] = max(best[second], len(found))
        loose = [v for v in textured if views[v].gray is not None and best[v] < WELL_TIED_MATCHES]

        def tilted(view: int) -> _PreparedView:
            features = with_tilts(views[view].features, views[view].gray, self.max_features)
            return replace(views[view], features=features)

        if loose:
            with ThreadPoolExecutor(max_workers=_worker_count(len(loose))) as pool:
                for view, prepared in zip(loose, pool.map(tilted, loose), strict=True):
                    views[view] = prepared
            again = [key for key in matches if key[0] in loose or key[1] in loose]
            features = [view.features for view in views]
            with ThreadPoolExecutor(max_workers=_worker_count(len(again))) as pool:
                found = pool.map(lambda key: match_features(features[key[0]], features[key[1]]), again)
                matches = {**matches, **dict(zip(again, found, strict=True))}
        return [replace(view, gray=None) for view in views], matches

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
        support = None  # per point, how many views agree on it (its confidence)
        if model.pure_rotation:
            warnings.append(
                "the views only rotate about one point: depth is undefined, so the cloud lies on a unit "
                "sphere around the camera"
            )
            points, colors = unit_sphere_cloud(samples)
        else:
            points, colors = sparse_points, _sparse_colors(views, model)
            support = np.array([len(track) for track in model.tracks], dtype=np.float32)
            if use_densify:
                dense = densify(samples)
                points = np.concatenate([points, dense.points])
                colors = np.concatenate([colors, dense.colors])
                support = np.concatenate([support, dense.support.astype(np.float32)])
                depth_maps = dense.depth_maps
            scale = _scale_to_unit_median_distance(points)
            points = points * scale
            extrinsics = {
                view: np.concatenate([e[:, :3], e[:, 3:] * scale], axis=1) for view, e in extrinsics.items()
            }
            if depth_maps is not None:
                depth_maps = {view: depth * np.float32(scale) for view, depth in depth_maps.items()}
        return self._reconstruction(views, extrinsics, points, colors, depth_maps, warnings, support)

    def _reconstruction(
        self,
        views: list[_PreparedView],
        extrinsics: dict[int, np.ndarray],
        points: np.ndarray,
        colors: np.ndarray,
        depth_maps: dict[int, np.ndarray] | None,
        warnings: list[str],
        support: np.ndarray | None = None,
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
            point_confidence=support,
        )


def _match_pairs(features: list[ViewFeatures], textured: list[int]) -> dict[tuple[int, int], np.ndarray]:
    """Matches of every pair of textured views, keyed (first, second) with first < second."""
    keys = [(first, second) for position, first in enumerate(textured) for second in textured[position + 1 :]]
    # One pair per core (BLAS is on one thread, see blas_threads.py).
    with ThreadPoolExecutor(max_workers=_worker_count(len(keys))) as pool:
        found = pool.map(lambda key: match_features(features[key[0]], features[key[1]]), keys)
        return dict(zip(keys, found, strict=True))


def _worker_count(tasks: int) -> int:
    return max(1, min(tasks, os.cpu_count() or 1))


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


GIVEN_SOURCES = ("uploaded", "exif")


def _given_intrinsics(
    intrinsics: Sequence[np.ndarray | None] | None, sources: Sequence[str | None] | None, count: int
) -> tuple[list[np.ndarray | None], list[str]]:
    """Validated per-view given intrinsics (or None) and the source label of every view so far."""
    if intrinsics is None:
        return [None] * count, ["prior"] * count
    if len(intrinsics) != count:
        raise BackboneError(f"got intrinsics for {len(intrinsics)} views but {count} images")
    if sources is not None and len(sources) != count:
        raise BackboneError(f"got {len(sources)} intrinsics sources for {count} images")
    given: list[np.ndarray | None] = []
    labels = []
    for index, intrinsic in enumerate(intrinsics):
        if intrinsic is None:
            given.append(None)
            labels.append("prior")
            continue
        matrix = np.asarray(intrinsic, dtype=np.float64)
        usable = matrix.shape == (3, 3) and np.all(np.isfinite(matrix))
        if not usable or matrix[0, 0] <= 0 or matrix[1, 1] <= 0:
            raise BackboneError(
                f"intrinsics of view {index + 1} must be a finite 3x3 with positive focal lengths"
            )
        label = (sources[index] if sources is not None else None) or "uploaded"
        if label not in GIVEN_SOURCES:
            raise BackboneError(
                f"intrinsics source of view {index + 1} must be one of {GIVEN_SOURCES}, got {label!r}"
            )
        given.append(matrix)
        labels.append(label)
    return given, labels


def _confidence_in_image_pixels(
    views: Sequence[_PreparedView],
    solution: Solution,
    textured: Sequence[int],
    warnings: list[str],
) -> tuple[list[ViewConfidence], list[PairConfidence]]:
    """Per-view and per-pair confidence of a solution, with a reason for every view left out.

    The solver measures reprojection errors in working pixels (the downscaled images); these are
    reported in original-image pixels. Appends one warning per unregistered view."""
    reasons = dict(solution.unregistered_reasons)
    for index in range(len(views)):
        if index not in solution.model.extrinsics and index not in reasons:
            reasons[index] = (
                "too little texture" if index not in textured else "too few reliable matches to placed views"
            )
    for index, reason in sorted(reasons.items()):
        warnings.append(f"view {index + 1} could not be registered ({reason}); its extrinsic is NaN")
    confidence = [
        solution.view_confidence.get(index, ViewConfidence(unregistered_reason=reasons.get(index)))
        for index in range(len(views))
    ]
    for index, reason in reasons.items():
        confidence[index] = replace(confidence[index], unregistered_reason=reason)
    # Confidence was measured in working pixels; report original-image pixels.
    confidence = [
        replace(item, reprojection_error_px=item.reprojection_error_px / view.scale)
        for item, view in zip(confidence, views, strict=True)
    ]
    pair_confidence = [
        replace(
            pair,
            reprojection_error_px=pair.reprojection_error_px
            * 2
            / (views[pair.first].scale + views[pair.second].scale),
        )
        for pair in solution.pair_confidence
    ]
    return confidence, pair_confidence
