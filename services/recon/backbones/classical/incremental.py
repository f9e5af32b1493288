"""Incremental registration of views into one sparse model.

1. Start from the pair with the most essential-matrix inliers among pairs with real parallax:
   its first camera is the origin, its baseline is 1, its inliers are triangulated. (When no pair
   yields enough points, the best pair with some parallax still starts the model.)
2. Repeatedly register the unplaced view with the most 2D-3D correspondences by PnP (RANSAC, then
   Levenberg-Marquardt). When no view has enough, chain a pairwise pose from a placed view: a pure
   rotation keeps the neighbour's centre; an essential pose gets its baseline length from the
   depths of points both views already share, or, failing that, the typical baseline of the
   placed cameras (with a warning: that view's distance is a guess, its direction is not).
3. After each new view, extend tracks and triangulate the new matches with every placed view.
4. Re-triangulate every point from all its observations and drop the observations that do not
   fit. Poses and points are then refined together by the bundle adjustment that follows every
   build (solve.py). Four rounds of per-camera pose refinement here used to come first; they only
   repeated the adjustment's work (templeRing's accuracy tables are the same without them).

When no pair has parallax, the set is treated as rotations about one centre and chained along
the strongest rotation pairs, then refined on all matched rays. Views that nothing connects stay unplaced.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from .geometry import bearings, camera_center, compose, project, rotation_between_bearings
from .triangulation import (
    MAX_REPROJECTION_PX,
    MIN_RAY_ANGLE_DEG,
    max_ray_angle_deg,
    projection_matrix,
    stacked_observations,
    triangulate_many_views,
    triangulate_pair,
)
from .two_view import TwoViewGeometry

MIN_INIT_PARALLAX_DEG = 2.0  # an initial pair needs rays that meet at a useful angle
MIN_PARALLAX_DEG = 1.0  # below this a pair's translation is noise: it counts as a rotation
MIN_INIT_POINTS = 25
MIN_PNP_CORRESPONDENCES = 15
MIN_PNP_INLIER_SHARE = 0.25
PNP_THRESHOLD_PX = 3.0
MIN_SCALE_POINTS = 5  # shared points needed to give a chained essential pose its baseline
ROTATION_REFINE_ROUNDS = 4  # rotation-only sets: no adjustment follows, so they refine here


@dataclass
class SparseModel:
    extrinsics: dict[int, np.ndarray]  # view -> 3x4 camera-from-world, working-image pixels
    points: np.ndarray  # (P, 3)
    tracks: list[dict[int, int]]  # per point: view -> keypoint index
    pure_rotation: bool  # every placed view shares one centre; depth is undefined
    warnings: list[str] = field(default_factory=list)
    # Views placed at a guessed distance from an anchor view (no shared 3D points): view -> anchor.
    guessed_distance: dict[int, int] = field(default_factory=dict)


@dataclass(frozen=True)
class _Relative:
    rotation: np.ndarray
    translation: np.ndarray
    matches: np.ndarray  # (M, 2): keypoint in the "from" view, keypoint in the "to" view
    model: str


class IncrementalMapper:
    def __init__(
        self,
        keypoints: list[np.ndarray],
        intrinsics: list[np.ndarray],
        pairs: dict[tuple[int, int], TwoViewGeometry],
    ) -> None:
        self.keypoints = keypoints
        self.intrinsics = intrinsics
        self.pairs = pairs  # keyed (i, j) with i < j
        self.num_views = len(keypoints)
        self.extrinsics: dict[int, np.ndarray] = {}
        self.points: list[np.ndarray] = []
        self.tracks: list[dict[int, int]] = []
        self.observed: dict[tuple[int, int], int] = {}  # (view, keypoint) -> point id
        self.warnings: list[str] = []
        self.guessed_distance: dict[int, int] = {}

    # ---- public ---------------------------------------------------------------------------

    def run(self) -> SparseModel:
        if self._initialize():
            self._register_remaining()
            self._retriangulate()  # poses and points are refined by the adjustment after the build
            pure_rotation = False
        else:
            self._register_rotations_only()
            pure_rotation = True
        points = np.array(self.points, dtype=np.float64).reshape(-1, 3)
        return SparseModel(
            dict(self.extrinsics),
            points,
            list(self.tracks),
            pure_rotation,
            self.warnings,
            dict(self.guessed_distance),
        )

    # ---- pairs ----------------------------------------------------------------------------

    def _relative(self, source: int, target: int) -> _Relative | None:
        """Pose of `target` relative to `source`, whichever order the pair was stored in."""
        if (source, target) in self.pairs:
            pair = self.pairs[(source, target)]
            return _Relative(pair.rotation, pair.translation, pair.matches, pair.model)
        if (target, source) in self.pairs:
            pair = self.pairs[(target, source)]
            rotation = pair.rotation.T
            return _Relative(rotation, -rotation @ pair.translation, pair.matches[:, ::-1], pair.model)
        return None

    # ---- initialization -------------------------------------------------------------------

    def _initialize(self) -> bool:
        candidates = [
            key
            for key, pair in self.pairs.items()
            if not pair.is_rotation and pair.median_parallax_deg >= MIN_PARALLAX_DEG
        ]
        candidates.sort(
            key=lambda key: (
                self.pairs[key].median_parallax_deg >= MIN_INIT_PARALLAX_DEG,
                len(self.pairs[key].matches),
            ),
            reverse=True,
        )
        for first, second in candidates[:5]:
            self._start_from(first, second)
            if len(self.points) >= MIN_INIT_POINTS:
                return True
        if not candidates:
            self.extrinsics, self.points, self.tracks, self.observed = {}, [], [], {}
            return False
        # Few points anywhere (wide viewpoint changes): the strongest pair still fixes the frame.
        self._start_from(*candidates[0])
        return True

    def _start_from(self, first: int, second: int) -> None:
        pair = self.pairs[(first, second)]
        self.extrinsics = {
            first: compose(np.eye(3), np.zeros(3)),
            second: compose(pair.rotation, pair.translation),
        }
        self.points, self.tracks, self.observed = [], [], {}
        self._triangulate_new(first, second)

    # ---- registration ---------------------------------------------------------------------

    def _register_remaining(self) -> None:
        while len(self.extrinsics) < self.num_views:
            placed = self._register_next_by_pnp()
            if placed is None:  # view 0 is a valid answer, so compare with None, not truthiness
                placed = self._register_next_by_chaining(guess_baseline=False)
            if placed is None:
                placed = self._register_next_by_chaining(guess_baseline=True)
            if placed is None:
                return
            for other in list(self.extrinsics):
                if other != placed:
                    self._extend_tracks(other, placed)
                    self._triangulate_new(other, placed)

    def _unplaced(self) -> list[int]:
        return [view for view in range(self.num_views) if view not in self.extrinsics]

    def _correspondences(self, view: int) -> tuple[np.ndarray, np.ndarray]:
        """World points and this view's pixels for its matches to already triangulated points."""
        point_ids: dict[int, int] = {}  # keypoint of `view` -> point id
        for other in self.extrinsics:
            relative = self._relative(other, view)
            if relative is None:
                continue
            for other_keypoint, keypoint in relative.matches:
                point = self.observed.get((other, int(other_keypoint)))
                if point is not None and int(keypoint) not in point_ids:
                    point_ids[int(keypoint)] = point
        if not point_ids:
            return np.zeros((0, 3)), np.zeros((0, 2))
        keypoints = np.array(list(point_ids), dtype=np.int64)
        world = np.array([self.points[point_ids[k]] for k in keypoints])
        return world, self.keypoints[view][keypoints]

    def _register_next_by_pnp(self) -> int | None:
        found = {view: self._correspondences(view) for view in self._unplaced()}
        ranked = sorted(found, key=lambda v: len(found[v][0]), reverse=True)
        for view in ranked:
            world, pixels = found[view]
            if len(world) < MIN_PNP_CORRESPONDENCES:
                return None
            extrinsic = _solve_pnp(world, pixels, self.intrinsics[view])
            if extrinsic is not None:
                self.extrinsics[view] = extrinsic
                return view
        return None

    def _register_next_by_chaining(self, guess_baseline: bool) -> int | None:
        options = []
        for view in self._unplaced():
            for anchor in self.extrinsics:
                relative = self._relative(anchor, view)
                if relative is not None:
                    options.append((len(relative.matches), anchor, view, relative))
        for _, anchor, view, relative in sorted(options, key=lambda option: option[0], reverse=True):
            extrinsic = self._chained_pose(anchor, view, relative, guess_baseline)
            if extrinsic is not None:
                self.extrinsics[view] = extrinsic
                return view
        return None

    def _chained_pose(
        self, anchor: int, view: int, relative: _Relative, guess_baseline: bool
    ) -> np.ndarray | None:
        anchor_pose = self.extrinsics[anchor]
        rotation = relative.rotation @ anchor_pose[:, :3]
        if relative.model == "rotation":
            return compose(rotation, relative.rotation @ anchor_pose[:, 3])
        baseline = self._baseline_from_shared_depths(anchor, view, relative)
        if baseline is None:
            if not guess_baseline:
                return None
            baseline = self._typical_baseline()
            self.guessed_distance[view] = anchor
            self.warnings.append(
                f"view {view + 1}: its distance from view {anchor + 1} is a guess (no shared 3D points); "
                "its direction and rotation are estimated"
            )
        # x_view = R_rel x_anchor + baseline * t_rel, with x_anchor = anchor pose applied to world.
        return compose(rotation, relative.rotation @ anchor_pose[:, 3] + baseline * relative.translation)

    def _typical_baseline(self) -> float:
        centres = np.array([camera_center(extrinsic) for extrinsic in self.extrinsics.values()])
        gaps = np.linalg.norm(centres[:, None] - centres[None], axis=2)
        gaps = gaps[gaps > 1e-9]
        return float(np.median(gaps)) if len(gaps) else 1.0

    def _baseline_from_shared_depths(self, anchor: int, view: int, relative: _Relative) -> float | None:
        """Length of the unit pairwise baseline that matches the depths the model already has."""
        local_first = compose(np.eye(3), np.zeros(3))
        local_second = compose(relative.rotation, relative.translation)
        anchor_pixels = self.keypoints[anchor][relative.matches[:, 0]]
        view_pixels = self.keypoints[view][relative.matches[:, 1]]
        local_points, sound = triangulate_pair(
            local_first,
            local_second,
            self.intrinsics[anchor],
            self.intrinsics[view],
            anchor_pixels,
            view_pixels,
        )
        ratios = []
        for index, (anchor_keypoint, _) in enumerate(relative.matches):
            point = self.observed.get((anchor, int(anchor_keypoint)))
            if point is None or not sound[index]:
                continue
            _, model_depth = project(
                self.points[point][None], self.extrinsics[anchor], self.intrinsics[anchor]
            )
            ratios.append(model_depth[0] / local_points[index, 2])
        if len(ratios) < MIN_SCALE_POINTS or np.median(ratios) <= 0:
            return None
        return float(np.median(ratios))

    # ---- tracks and triangulation ---------------------------------------------------------

    def _extend_tracks(self, first: int, second: int) -> None:
        """Add a placed view's observation to a point its partner already sees, when it fits."""
        relative = self._relative(first, second)
        if relative is None or not self.points:
            return
        # Every point projected into both views once (this adds observations, never points).
        world = np.array(self.points)
        projected = {
            view: project(world, self.extrinsics[view], self.intrinsics[view]) for view in (first, second)
        }
        for keypoint_a, keypoint_b in relative.matches.tolist():
            for (view_has, key_has), (view_new, key_new) in (
                ((first, keypoint_a), (second, keypoint_b)),
                ((second, keypoint_b), (first, keypoint_a)),
            ):
                point = self.observed.get((view_has, int(key_has)))
                if (
                    point is None
                    or (view_new, int(key_new)) in self.observed
                    or view_new in self.tracks[point]
                ):
                    continue
                predicted, depth = projected[view_new]
                if (
                    depth[point] > 0
                    and np.linalg.norm(predicted[point] - self.keypoints[view_new][key_new])
                    < MAX_REPROJECTION_PX
                ):
                    self.tracks[point][view_new] = int(key_new)
                    self.observed[(view_new, int(key_new))] = point

    def _triangulate_new(self, first: int, second: int) -> None:
        relative = self._relative(first, second)
        if relative is None:
            return
        fresh = np.array(
            [
                (self.observed.get((first, int(a))) is None and self.observed.get((second, int(b))) is None)
                for a, b in relative.matches
            ],
            dtype=bool,
        )
        matches = relative.matches[fresh]
        points, sound = triangulate_pair(
            self.extrinsics[first],
            self.extrinsics[second],
            self.intrinsics[first],
            self.intrinsics[second],
            self.keypoints[first][matches[:, 0]],
            self.keypoints[second][matches[:, 1]],
        )
        for (keypoint_a, keypoint_b), point in zip(matches[sound], points[sound], strict=True):
            point_id = len(self.points)
            self.points.append(point)
            self.tracks.append({first: int(keypoint_a), second: int(keypoint_b)})
            self.observed[(first, int(keypoint_a))] = point_id
            self.observed[(second, int(keypoint_b))] = point_id

    # ---- refinement -----------------------------------------------------------------------

    def _retriangulate(self) -> None:
        """Re-solve every point from all its observations; drop observations that do not fit."""
        if not self.points:
            return
        views = sorted(self.extrinsics)
        slot = {view: index for index, view in enumerate(views)}
        matrices = {view: projection_matrix(self.extrinsics[view], self.intrinsics[view]) for view in views}
        projections, pixels, seen = stacked_observations(self.tracks, views, self.keypoints, matrices)
        solved = triangulate_many_views(projections, pixels, seen)
        fits = seen.copy()
        for view in views:
            predicted, depth = project(np.nan_to_num(solved), self.extrinsics[view], self.intrinsics[view])
            error = np.linalg.norm(predicted - pixels[:, slot[view]], axis=1)
            fits[:, slot[view]] &= (depth > 0) & (error < MAX_REPROJECTION_PX)
        keep = np.all(np.isfinite(solved), axis=1) & (fits.sum(axis=1) >= 2) & np.all(fits == seen, axis=1)
        keep &= self._ray_angles(solved, fits, views) >= MIN_RAY_ANGLE_DEG
        self._keep_points(solved, keep)

    def _ray_angles(self, points: np.ndarray, seen: np.ndarray, views: list[int]) -> np.ndarray:
        widest = np.zeros(len(points))
        for a in range(len(views)):
            for b in range(a + 1, len(views)):
                both = seen[:, a] & seen[:, b]
                if both.any():
                    pair_angle = max_ray_angle_deg(
                        np.nan_to_num(points[both]), [self.extrinsics[views[a]], self.extrinsics[views[b]]]
                    )
                    widest[both] = np.maximum(widest[both], pair_angle)
        return widest

    def _keep_points(self, points: np.ndarray, keep: np.ndarray) -> None:
        self.points = [points[i] for i in np.flatnonzero(keep)]
        self.tracks = [self.tracks[i] for i in np.flatnonzero(keep)]
        self.observed = {
            (view, keypoint): point
            for point, track in enumerate(self.tracks)
            for view, keypoint in track.items()
        }

    # ---- rotation-only sets ---------------------------------------------------------------

    def _register_rotations_only(self) -> None:
        """Chain pairwise rotations along the strongest pairs, then refine on all matched rays."""
        self.pairs = {
            key: pair
            for key, pair in self.pairs.items()
            if pair.is_rotation or pair.median_parallax_deg < MIN_PARALLAX_DEG
        }
        connected = sorted({view for key in self.pairs for view in key})
        if not connected:
            return
        self.extrinsics = {connected[0]: compose(np.eye(3), np.zeros(3))}
        while True:
            options = [
                (len(relative.matches), anchor, view, relative)
                for view in self._unplaced()
                for anchor in self.extrinsics
                if (relative := self._relative(anchor, view)) is not None
            ]
            if not options:
                break
            _, anchor, view, relative = max(options, key=lambda option: option[0])
            self.extrinsics[view] = compose(relative.rotation @ self.extrinsics[anchor][:, :3], np.zeros(3))
        if any(not pair.is_rotation for pair in self.pairs.values()):
            self.warnings.append(
                "some pairs had a little parallax, too little to triangulate: taken as rotations"
            )
        reference = connected[0]
        for _ in range(ROTATION_REFINE_ROUNDS):
            for view in self.extrinsics:
                if view != reference:
                    self._refine_rotation(view)

    def _refine_rotation(self, view: int) -> None:
        """Best rotation of one view against the world directions of its matches to placed views."""
        own_rays, world_rays = [], []
        for anchor in self.extrinsics:
            relative = self._relative(anchor, view) if anchor != view else None
            if relative is None:
                continue
            anchor_rays = bearings(self.keypoints[anchor][relative.matches[:, 0]], self.intrinsics[anchor])
            world_rays.append(anchor_rays @ self.extrinsics[anchor][:, :3])  # R^T applied to each ray
            own_rays.append(bearings(self.keypoints[view][relative.matches[:, 1]], self.intrinsics[view]))
        if world_rays:
            rotation = rotation_between_bearings(np.concatenate(world_rays), np.concatenate(own_rays))
            self.extrinsics[view] = compose(rotation, np.zeros(3))


def _solve_pnp(world: np.ndarray, pixels: np.ndarray, intrinsic: np.ndarray) -> np.ndarray | None:
    found, rvec, tvec, inliers = cv2.solvePnPRansac(
        world.astype(np.float64),
        pixels.astype(np.float64),
        intrinsic,
        None,
        iterationsCount=2000,
        reprojectionError=PNP_THRESHOLD_PX,
        confidence=0.9999,
        flags=cv2.SOLVEPNP_SQPNP,
    )
    if not found or inliers is None:
        return None
    inliers = inliers.ravel()
    if len(inliers) < MIN_PNP_CORRESPONDENCES or len(inliers) < MIN_PNP_INLIER_SHARE * len(world):
        return None
    rvec, tvec = cv2.solvePnPRefineLM(world[inliers], pixels[inliers], intrinsic, None, rvec, tvec)
    extrinsic = compose(cv2.Rodrigues(rvec)[0], tvec.ravel())
    if not np.all(np.isfinite(extrinsic)):
        return None
    return extrinsic
