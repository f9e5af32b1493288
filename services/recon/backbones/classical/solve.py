"""Poses, points and the unknown focal length together: self-calibration, adjustment, verification.

Self-calibration by alternation. The two-view poses and the incremental model are built with the
current focal (the field-of-view prior at first); bundle adjustment then refines the focal shared
by the views whose camera is unknown. A wrong focal bends the model (rotations come out scaled,
translations can even flip), but adjustment still moves the focal towards the truth; rebuilding
the model with the moved focal and adjusting again converges in a few rounds (on templeRing, a
60 degree prior for a 24 degree lens: 554 -> 1494 -> 1541 px, true 1520). A round ends
the alternation when the focal moved by under 2%, or by under 16% in an adjustment that converged
(rather than stopping at its iteration cap): that model is already refined with the free focal,
and a rebuild would only confirm it. Given intrinsics stay fixed throughout.

The rounds adjust a spread subsample of at most 500 tracks (calibration_sample.py), up to 300
iterations each: the focal is what they are for, and a few hundred tracks fix it about as well as
all of them at a quarter of the cost, so the first round can run to convergence rather than creep
from the prior at an iteration cap; round one, far from the focal, goes coarse to fine (100 of
the sample's tracks first, see calibration_sample.py), which halves its cost. The calibrated model
then gets one adjustment over every track, its other points re-triangulated on the sample's poses
first; the focal is refined in it once more (about 1%: templeRing [24..27] 1541 -> 1519 px). The
prior-fits-as-well test compares the samples' costs per observation; each of its adjustments
runs coarse to fine and stops after the coarse stage when that already shows the prior's cost
above the bound by 3 standard errors (_evidently_dearer). A rebuild re-fits what the focal
changes (the essential matrices) and reuses the pairs' homography fits, which it does not.

The estimate must earn its place: the prior is kept when it explains the matches (adjusted, robust
cost) within 5% as well. That is the case when the focal is not observable (two views, views
whose optical axes meet at one point) and when the prior is simply right; it stops a focal pulled
off by a weakly connected view. An implausible estimate (field of view outside
MIN_FOV_DEG..MAX_FOV_DEG) also falls back to the prior. Either way the views say "prior".
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from shared.geometry.motion_determinacy import FocalHypotheses
from shared.geometry.reconstruction import PairConfidence, ViewConfidence

from ..base import BackboneError
from .bundle_adjustment import bundle_adjust, robust_cost, track_costs
from .calibration_sample import (
    CoarseStage,
    adjusted_coarse_to_fine,
    adjusted_model,
    calibration_sample,
    coarse_stage,
    fine_stage,
    sampled,
    with_focal,
    with_sample_adjusted,
)
from .focal_hypotheses import flag_hypothesis_views, horizontal_fov_deg, solve_over_focal
from .incremental import IncrementalMapper, SparseModel
from .intrinsics import guess_intrinsics
from .pair_uncertainty import assess_pairs, flag_guessed_distances
from .plane_prior import narrow_by_orthogonal_planes
from .rotation_verification import rotation_model_reasons
from .two_view import MIN_INLIERS, HomographyFit, TwoViewGeometry, estimate_two_view, fit_homography
from .verification import (
    MIN_CONFIDENT_ANGLE_DEG,
    disagreement_with_pairs,
    observations,
    pair_confidences,
    rejection_reason,
    view_confidence,
    weakly_tied_views,
)

MAX_CALIBRATION_ROUNDS = 5
# Iteration cap of the calibration rounds' adjustments (on at most 500 tracks, so cheap): the first
# round, from the 60 degree prior, then mostly converges near the truth rather than creeping.
CALIBRATION_ITERATIONS = 300
CONVERGED_CHANGE = 0.02  # relative focal change that counts as settled
# A larger change still counts as settled when the adjustment converged (not stopped by its
# iteration cap): the model was then refined with the free focal to a minimum already, and the
# final adjustment over all tracks refines the focal once more, so a rebuild at the moved focal
# only confirms it (templeRing [16, 19, 22, 25]: 1357 -> 1524, finally 1531; [8..11]: 1329 ->
# 1499, finally 1497, where one more round had wandered to 1465).
SETTLED_IF_CONVERGED_CHANGE = 0.16
MIN_FOV_DEG, MAX_FOV_DEG = 5.0, 140.0
# The estimated focal replaces the prior only when the prior's adjusted cost is this much higher.
# On templeRing a 1.4x wrong focal costs two views +0.1..0.5%, three or more views +20..150%.
MAX_PRIOR_COST_RISE = 1.05
# Standard errors by which the coarse tracks' mean excess over that bound must exceed zero for the
# prior check to stop before its last adjustment (_evidently_dearer).
EVIDENT_EXCESS_SE = 3.0


@dataclass
class Solution:
    model: SparseModel  # adjusted and verified; working-image pixels
    intrinsics: list[np.ndarray]  # per view, working pixels (free views: the self-calibrated focal)
    free_focal_source: str  # "self-calibrated" or "prior": the label of views without given intrinsics
    view_confidence: dict[int, ViewConfidence]
    pair_confidence: list[PairConfidence]
    unregistered_reasons: dict[int, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    # Set when the free focal is not observable: the pairs solved over a grid of fields of view.
    focal_hypotheses: FocalHypotheses | None = None


def relate_pairs(
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    matches: dict[tuple[int, int], np.ndarray],
    homographies: dict[tuple[int, int], HomographyFit] | None = None,
) -> dict[tuple[int, int], TwoViewGeometry]:
    """Two-view geometry of every matched pair; `homographies` (fit_homographies, at any focal)
    spare the homography fits, which do not depend on the intrinsics."""
    known = homographies or {}

    def relate(key: tuple[int, int]) -> TwoViewGeometry | None:
        first, second = key
        return estimate_two_view(
            keypoints[first],
            keypoints[second],
            intrinsics[first],
            intrinsics[second],
            matches[key],
            known.get(key),
        )

    found = _each_pair(relate, list(matches))
    return {key: geometry for key, geometry in found.items() if geometry is not None}


def fit_homographies(
    keypoints: list[np.ndarray], intrinsics: list[np.ndarray], matches: dict[tuple[int, int], np.ndarray]
) -> dict[tuple[int, int], HomographyFit]:
    """Every pair's homography fit (two_view.HomographyFit), for the builds at each focal."""

    def fit(key: tuple[int, int]) -> HomographyFit:
        first, second = key
        return fit_homography(
            keypoints[first], keypoints[second], intrinsics[first], intrinsics[second], matches[key]
        )

    keys = [key for key, found in matches.items() if len(found) >= MIN_INLIERS]
    return _each_pair(fit, keys)


def _each_pair(task, keys: list[tuple[int, int]]) -> dict:
    # OpenCV's RANSAC fits release the GIL and seed their own generator per call, so pairs can
    # be related side by side with the same result as one after the other.
    with ThreadPoolExecutor(max_workers=max(1, min(len(keys), os.cpu_count() or 1))) as pool:
        return dict(zip(keys, pool.map(task, keys), strict=True))


# Long on purpose: the alternation of model building and focal refinement reads as one loop.
def solve_with_self_calibration(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    intrinsics: list[np.ndarray],
    free: list[bool],
    matches: dict[tuple[int, int], np.ndarray],
) -> Solution:
    prior = [intrinsic.copy() for intrinsic in intrinsics]
    current = [intrinsic.copy() for intrinsic in intrinsics]
    homographies = fit_homographies(keypoints, prior, matches)  # the same at every focal: fitted once
    calibrate = any(free)
    warnings: list[str] = []
    source = "prior"
    adjusted_last = False  # whether `model` is already adjusted with the final intrinsics
    prior_sample = None  # the calibration sample of the prior's build
    prior_build = None  # the model the prior focal gives, kept to compare with the calibrated one
    for round_index in range(MAX_CALIBRATION_ROUNDS if calibrate else 1):
        pairs, model = _build(keypoints, current, matches, homographies)
        prior_build = prior_build or (pairs, model)
        if model.pure_rotation or len(model.points) == 0:
            break  # no triangulated points: nothing for adjustment to refine
        if not calibrate:
            adjusted = bundle_adjust(
                keypoints, image_sizes, current, free, model.extrinsics, model.points, model.tracks, False
            )
            model, adjusted_last = adjusted_model(model, adjusted), True
            break
        sample = calibration_sample(model, keypoints, image_sizes)
        prior_sample = prior_sample if round_index else sample  # the prior's build is round one's
        subset = sampled(model, sample)
        # Round one starts at the prior, far from the focal: coarse to fine. A rebuilt model is near
        # its focal already, where one adjustment is quicker (and a coarse stage can overshoot).
        staged = round_index == 0
        adjusted = adjusted_coarse_to_fine(
            keypoints, image_sizes, current, free, subset, True, CALIBRATION_ITERATIONS, staged
        )
        focal_before = {v: current[v][0, 0] for v in adjusted.intrinsics if free[v]}
        focal_after = {v: adjusted.intrinsics[v][0, 0] for v in focal_before}
        if not focal_after:
            break
        if not all(_plausible(focal_after[v], image_sizes[v][0]) for v in focal_after):
            warnings.append(
                "the focal length estimated from the views is implausible; the views without given "
                "intrinsics use the field-of-view prior"
            )
            current, source = prior, "prior"
            pairs, model = _build(keypoints, current, matches, homographies)
            break
        current = with_focal(current, free, focal_after, image_sizes)
        subset, source = adjusted_model(subset, adjusted), "self-calibrated"
        change = max(abs(focal_after[v] - focal_before[v]) / focal_before[v] for v in focal_after)
        settled = change < CONVERGED_CHANGE or (adjusted.converged and change < SETTLED_IF_CONVERGED_CHANGE)
        # Two views usually cannot fix the focal: ask at once rather than after every round has
        # crept along the flat cost.
        two_views_at_first = len(subset.extrinsics) == 2 and round_index == 0
        last = round_index == MAX_CALIBRATION_ROUNDS - 1
        if settled or two_views_at_first or last:
            prior_subset = sampled(prior_build[1], prior_sample)
            if _prior_fits_as_well(keypoints, image_sizes, current, prior, free, subset, prior_subset):
                source = "undetermined"
                break
            if settled or last:
                if sample is None:
                    model, adjusted_last = subset, True
                else:  # the other tracks follow the sample's poses; all are adjusted below
                    model = with_sample_adjusted(model, sample, subset, keypoints, current)
                break
    if source == "undetermined":
        warnings.append(
            "the focal length cannot be determined from these views: the field-of-view prior fits "
            "them as well as any estimate (two views, or views whose optical axes meet at one "
            "point, fit a range of focals), so the prior is used and rotations may be off by "
            "several degrees if the camera differs; give the intrinsics for accurate poses"
        )
        current, source, adjusted_last = prior, "prior", False
        pairs, model = prior_build
    if not adjusted_last and not model.pure_rotation and len(model.points):
        # A focal calibrated on a sample of the tracks is refined once more on all of them.
        refine = source == "self-calibrated"
        adjusted = bundle_adjust(
            keypoints, image_sizes, current, free, model.extrinsics, model.points, model.tracks, refine
        )
        model = adjusted_model(model, adjusted)
        if refine:
            focal = {v: adjusted.intrinsics[v][0, 0] for v in adjusted.intrinsics if free[v]}
            current = with_focal(current, free, focal, image_sizes)
    solution = _verified(keypoints, image_sizes, current, free, pairs, model, source, warnings)
    if _focal_unobservable(solution, free):
        return _over_focal_hypotheses(keypoints, image_sizes, current, free, matches, homographies, solution)
    return solution


def _focal_unobservable(solution: Solution, free: list[bool]) -> bool:
    """Placed views of unknown focal on the prior (not self-calibrated), or only two placed views
    one of which has an unknown focal (see _refuse_unobservable_focal); not a pure rotation, whose
    pose needs no baseline."""
    placed_free = [v for v in solution.model.extrinsics if free[v]]
    if not placed_free or solution.model.pure_rotation:
        return False
    return solution.free_focal_source == "prior" or len(solution.model.extrinsics) == 2


def _over_focal_hypotheses(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    intrinsics: list[np.ndarray],
    free: list[bool],
    matches: dict[tuple[int, int], np.ndarray],
    homographies: dict[tuple[int, int], HomographyFit],
    solution: Solution,
) -> Solution:
    """The solution with every placed pair solved over the field-of-view grid (focal_hypotheses.py),
    narrowed where the scene's planes allow (plane_prior.py), its poses rebuilt at the central
    hypothesis; two views without a supported one are refused."""
    given = [None if free[v] else k for v, k in enumerate(intrinsics)]
    hypotheses = solve_over_focal(keypoints, image_sizes, matches, solution.model.extrinsics, given)
    if hypotheses is None:
        _refuse_unobservable_focal(solution, free)
        return solution
    hypotheses = narrow_by_orthogonal_planes(hypotheses, keypoints, image_sizes, matches, given)
    prior_view = next(v for v in solution.model.extrinsics if free[v])
    prior_fov = horizontal_fov_deg(
        intrinsics[prior_view][0, 0], image_sizes[prior_view][0]
    )  # or self-calibrated
    central = [
        guess_intrinsics(*image_sizes[v], hypotheses.central_fov_deg) if free[v] else k.copy()
        for v, k in enumerate(intrinsics)
    ]
    rebuilt = solution
    common = _common_fovs(hypotheses)
    # The prior's poses stand when the prior is one of the supported hypotheses (no second build);
    # else the model is rebuilt at the central hypothesis.
    if not min(common) - 1.0 <= prior_fov <= max(common) + 1.0:
        try:
            pairs, model = _build(keypoints, central, matches, homographies)
            adjusted = bundle_adjust(
                keypoints, image_sizes, central, free, model.extrinsics, model.points, model.tracks, False
            )
            model = adjusted_model(model, adjusted)
            rebuilt = _verified(
                keypoints, image_sizes, central, free, pairs, model, "prior", solution.warnings
            )
        except BackboneError:
            rebuilt = solution  # the prior's model stands; the hypotheses still say what holds
    used = hypotheses.central_fov_deg if rebuilt is not solution else prior_fov
    hypotheses.central_fov_deg = float(used)
    confidence = flag_hypothesis_views(rebuilt.view_confidence, hypotheses, used)
    warning = _hypotheses_warning(hypotheses, used)
    return replace(
        rebuilt,
        focal_hypotheses=hypotheses,
        view_confidence=confidence,
        warnings=list(dict.fromkeys([*rebuilt.warnings, warning])),  # a rebuild repeats the model's
    )


def _hypotheses_warning(hypotheses: FocalHypotheses, used: float) -> str:
    """What a scene solved over focal hypotheses says: the range, the hypothesis the poses use,
    and the assumption about the scene that narrowed the range, if one did."""
    fovs = [fov for pair in hypotheses.pairs for fov in pair.fov_deg]
    warning = (
        f"the focal length is unknown and these views cannot fix it: each pair was solved at every "
        f"horizontal field of view from {min(fovs):g} to {max(fovs):g} degrees that the matches support; "
        f"the poses and renders use the central hypothesis, {used:.0f} degrees (the field-of-view "
        "prior when the matches support it, else the middle of the supported range), and camera "
        "motion says which of its words hold at every hypothesis (determined) and which do not"
    )
    if hypotheses.narrowed_by is None:
        return warning
    return warning + (
        f"; narrower fields of view were ruled out by assuming that {hypotheses.narrowed_by} "
        "(at those the reconstruction bends that angle well away from 90 degrees)"
    )


def _common_fovs(hypotheses: FocalHypotheses) -> list[float]:
    """The fields of view every solved pair supports, else those any pair supports."""
    pairs = hypotheses.pairs
    common = set(pairs[0].fov_deg).intersection(*(pair.fov_deg for pair in pairs[1:]))
    return sorted(common or {fov for pair in pairs for fov in pair.fov_deg})


def _refuse_unobservable_focal(solution: Solution, free: list[bool]) -> None:
    """Two placed views with an unknown focal: a guessed pose, so no pose.

    Two views whose optical axes meet at the object fit a range of focals almost equally well
    (templeRing: a 1.4x wrong focal changes the adjusted cost by < 0.5%), and a wrong focal turns
    the relative rotation: 5-34 degrees off on templeRing's 2-view subsets with the prior. A focal
    self-calibrated with more views does not help once verification has dropped them to two: the
    focal then rests on views the data did not support (templeRing 13-19-25-2: 34 degrees off;
    synthetic "among" scene 109: 36). Three or more placed views pin the focal (every templeRing
    subset self-calibrated within 1521-1588 px, true 1520). A pure rotation is left as it is."""
    model = solution.model
    unknown_focal = [v for v in model.extrinsics if free[v]]
    if model.pure_rotation or len(model.extrinsics) != 2 or not unknown_focal:
        return
    first, second = sorted(model.extrinsics)
    raise BackboneError(
        f"the focal length cannot be determined from two views (only views {first + 1} and {second + 1} "
        "could be placed, and two views fit a range of focal lengths), so their relative pose "
        "would be a guess; send the intrinsics or photos with an EXIF focal length "
        "(FocalLengthIn35mmFilm), or more views of the scene"
    )


def _build(
    keypoints: list[np.ndarray],
    intrinsics: list[np.ndarray],
    matches: dict[tuple[int, int], np.ndarray],
    homographies: dict[tuple[int, int], HomographyFit],
) -> tuple[dict[tuple[int, int], TwoViewGeometry], SparseModel]:
    pairs = relate_pairs(keypoints, intrinsics, matches, homographies)
    if not pairs:
        raise BackboneError(
            f"no two of the {len(keypoints)} images share enough matching features to be related"
        )
    model = IncrementalMapper(keypoints, intrinsics, pairs).run()
    if len(model.extrinsics) < 2:
        raise BackboneError("could not place two views relative to each other")
    return pairs, model


def _prior_fits_as_well(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    calibrated: list[np.ndarray],
    prior: list[np.ndarray],
    free: list[bool],
    model: SparseModel,
    prior_model: SparseModel,
) -> bool:
    """Whether the prior focal explains the matches within MAX_PRIOR_COST_RISE of the estimate.

    `model` is adjusted with the `calibrated` focal, so its cost is the minimum. The prior's cost
    is the better of re-adjusting that model and the model first built with the prior. Each is
    adjusted coarse to fine, and its coarse stage may settle the question (_evidently_dearer)."""
    by_view = {view: calibrated[view] for view in model.extrinsics}
    calibrated_costs = track_costs(keypoints, by_view, model.extrinsics, model.points, model.tracks)
    best = float(np.sum(calibrated_costs))
    per_observation = best / max(_observation_count(model), 1)
    # The model built with the prior first: it is the nearer start (built at the prior focal), and
    # when it fits, the other one need not be adjusted at all. Compare like with like: the two
    # models may hold different points, so the prior's own model is held to the calibrated cost
    # per observation, the calibrated model track by track.
    for start in (prior_model, model):
        if start is model:
            bound = MAX_PRIOR_COST_RISE * calibrated_costs
        else:
            bound = MAX_PRIOR_COST_RISE * per_observation * _observations_per_track(start)
        stage = coarse_stage(keypoints, image_sizes, prior, free, start, False)
        if _evidently_dearer(keypoints, stage, bound):
            continue
        adjusted = fine_stage(keypoints, image_sizes, free, stage, False)
        cost = robust_cost(keypoints, adjusted.intrinsics, adjusted.extrinsics, adjusted.points, start.tracks)
        if cost <= float(np.sum(bound)) or cost <= MAX_PRIOR_COST_RISE * 1e-9:
            return True
    return False


def _evidently_dearer(keypoints: list[np.ndarray], stage: CoarseStage, bound: np.ndarray) -> bool:
    """Whether the coarse stage of moving a model to the prior focal already shows that the prior
    costs more than `bound` (per track of the model: what it may cost there), beyond sampling noise.

    The test the fine stage would settle is sum over the tracks of (prior cost - bound) <= 0. The
    coarse tracks are a spread subsample of them, and their prior cost there is at most what the
    fine stage leaves them (the coarse stage minimized their cost alone), so their mean excess
    estimates the whole's from below; the question is settled when it is EVIDENT_EXCESS_SE standard
    errors above zero (per track: the observations of one point are not independent). On the
    tuning rings and templeRing the prior costs 1.2-7x the estimate; where the focal is not
    observable it is within 1%, and the fine stage runs."""
    if stage.tracks is None or stage.adjusted is None or len(stage.tracks) < 2:
        return False
    tracks = [stage.model.tracks[index] for index in stage.tracks]
    adjusted = stage.adjusted
    prior_costs = track_costs(keypoints, adjusted.intrinsics, adjusted.extrinsics, adjusted.points, tracks)
    excess = prior_costs - bound[stage.tracks]
    error = float(np.std(excess, ddof=1)) / math.sqrt(len(excess))
    return float(np.mean(excess)) > EVIDENT_EXCESS_SE * error


def _observations_per_track(model: SparseModel) -> np.ndarray:
    return np.array([sum(view in model.extrinsics for view in track) for track in model.tracks], dtype=float)


def _observation_count(model: SparseModel) -> int:
    return sum(sum(view in model.extrinsics for view in track) for track in model.tracks)


def _plausible(focal: float, width: int) -> bool:
    fov = math.degrees(2 * math.atan(width / 2 / focal)) if focal > 0 else 180.0
    return MIN_FOV_DEG <= fov <= MAX_FOV_DEG


# Long on purpose: the verification steps in their order, each with its reason for a refusal.
def _verified(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    intrinsics: list[np.ndarray],
    free: list[bool],
    pairs: dict[tuple[int, int], TwoViewGeometry],
    model: SparseModel,
    source: str,
    warnings: list[str],
) -> Solution:
    """Unregister the views the data does not support; report everyone's confidence."""
    warnings = [*warnings, *model.warnings]
    if model.pure_rotation:
        return _verified_rotations(keypoints, image_sizes, intrinsics, pairs, model, source, warnings)
    reasons: dict[int, str] = {}
    while True:  # a rejected view takes its points along; the rest are checked again
        by_view = {v: intrinsics[v] for v in model.extrinsics}
        seen = observations(keypoints, by_view, model.extrinsics, model.points, model.tracks)
        confidence = {v: view_confidence(v, seen, image_sizes[v], 1.0) for v in model.extrinsics}
        rejected = {}
        for view in model.extrinsics:
            prior_focal = free[view] and source == "prior"
            reason = rejection_reason(confidence[view], 1.0, prior_focal) or disagreement_with_pairs(
                view, model.extrinsics, pairs, keypoints, by_view
            )
            if reason is not None:
                rejected[view] = reason
        if not rejected:
            rejected = weakly_tied_views(
                pair_confidences(seen, model.extrinsics, model.points, [1.0] * len(keypoints))
            )
        if not rejected:
            break
        reasons.update(rejected)
        model = _without_views(model, set(rejected))
        if len(model.extrinsics) < 2:
            details = "; ".join(f"view {v + 1}: {r}" for v, r in sorted(reasons.items()))
            raise BackboneError(f"no two views could be placed with confidence ({details})")
        adjusted = bundle_adjust(
            keypoints, image_sizes, intrinsics, free, model.extrinsics, model.points, model.tracks, False
        )
        model = adjusted_model(model, adjusted)
    pair_confidence = assess_pairs(
        keypoints,
        intrinsics,
        model.extrinsics,
        model.tracks,
        pairs,
        pair_confidences(seen, model.extrinsics, model.points, [1.0] * len(keypoints)),
    )
    pair_confidence = flag_guessed_distances(pair_confidence, model.tracks, model.guessed_distance)
    for view in sorted(model.extrinsics):
        angles = [
            p.triangulation_angle_deg for p in pair_confidence if view in (p.first, p.second) and p.inliers
        ]
        if not angles or max(angles) < MIN_CONFIDENT_ANGLE_DEG:
            widest = f"{max(angles):.1f}" if angles else "no"
            reason = (
                f"its position is uncertain: its points are seen at shallow angles ({widest} degrees "
                f"median at best, {MIN_CONFIDENT_ANGLE_DEG:g} needed); its rotation is reliable"
            )
            confidence[view] = replace(confidence[view], uncertain_reason=reason)
            warnings.append(f"view {view + 1}'s {reason.removeprefix('its ')}")
    warnings += [
        f"the relative pose of views {p.first + 1} and {p.second + 1} is uncertain: {p.uncertain_reason}"
        for p in pair_confidence
        if p.uncertain_reason
    ]
    return Solution(model, intrinsics, source, confidence, pair_confidence, reasons, warnings)


def _verified_rotations(
    keypoints: list[np.ndarray],
    image_sizes: list[tuple[int, int]],
    intrinsics: list[np.ndarray],
    pairs: dict[tuple[int, int], TwoViewGeometry],
    model: SparseModel,
    source: str,
    warnings: list[str],
) -> Solution:
    """A rotation-only model through the same checks, on its matched rays (no points to check)."""
    reasons: dict[int, str] = {}
    while True:  # a refused view takes its rays along; the others are checked again
        confidence, rejected = rotation_model_reasons(
            keypoints, intrinsics, image_sizes, model.extrinsics, pairs
        )
        if not rejected:
            return Solution(model, intrinsics, source, confidence, [], reasons, warnings)
        reasons.update(rejected)
        model = _without_views(model, set(rejected))
        if len(model.extrinsics) < 2:
            details = "; ".join(f"view {v + 1}: {r}" for v, r in sorted(reasons.items()))
            raise BackboneError(f"no two views could be placed with confidence ({details})")


def _without_views(model: SparseModel, removed: set[int]) -> SparseModel:
    extrinsics = {v: e for v, e in model.extrinsics.items() if v not in removed}
    kept_points, kept_tracks = [], []
    for point, track in zip(model.points, model.tracks, strict=True):
        remaining = {v: k for v, k in track.items() if v in extrinsics}
        if len(remaining) >= 2:
            kept_points.append(point)
            kept_tracks.append(remaining)
    points = np.array(kept_points, dtype=np.float64).reshape(-1, 3)
    guessed = {v: a for v, a in model.guessed_distance.items() if v in extrinsics and a in extrinsics}
    return SparseModel(extrinsics, points, kept_tracks, model.pure_rotation, list(model.warnings), guessed)
