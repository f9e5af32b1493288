"""A view placed at a guessed distance flags the pairs whose direction may rest on the guess
(services/recon/backbones/classical/pair_uncertainty.py: flag_guessed_distances)."""

from __future__ import annotations

from bench.determinacy_synthetic import pair_motion
from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.intrinsics import guess_intrinsics
from services.recon.backbones.classical.pair_uncertainty import flag_guessed_distances
from shared.geometry.reconstruction import PairConfidence
from shared.synthetic.dataset import _scene_and_rig
from shared.synthetic.render import render_view


def _pair(first: int, second: int, inliers: int, reason: str | None = None) -> PairConfidence:
    return PairConfidence(first, second, inliers, 0.2, 20.0, 0.3, 0.3, reason)


def test_only_pairs_that_do_not_measure_their_direction_are_flagged_while_a_guess_is_untied():
    pairs = [_pair(0, 1, 80), _pair(0, 2, 60), _pair(1, 2, 3), _pair(1, 3, 0, "two models fit")]
    two_view_tracks = [{0: 1, 1: 2}, {0: 3, 2: 4}, {2: 5, 3: 6}]
    flagged = flag_guessed_distances(pairs, two_view_tracks, {2: 0})
    assert [p.uncertain_reason is None for p in flagged] == [True, True, False, False]
    assert "view 3 (from view 1) at a guessed distance" in flagged[2].uncertain_reason
    assert flagged[3].uncertain_reason.startswith("two models fit; ")  # the first reason is kept
    # A point seen by the guessed view and two others ties its distance: nothing is flagged.
    tied = [*two_view_tracks, {0: 7, 1: 8, 2: 9}]
    assert flag_guessed_distances(pairs, tied, {2: 0}) == pairs
    assert flag_guessed_distances(pairs, two_view_tracks, {}) == pairs


def test_two_views_that_share_no_point_get_no_motion_when_the_model_guessed_a_distance():
    """The synthetic "among" rig that answered wrong before: views 2 and 4 face each other and
    share no feature; view 4 was placed at a guessed distance from view 1, and the direction from
    view 2 to view 4 came out 33 degrees off, unflagged."""
    scene, rig, _ = _scene_and_rig(3, 17, "among")
    intrinsic = guess_intrinsics(320, 240, 80.0)
    images = [render_view(scene, extrinsic, intrinsic, 320, 240).rgb for extrinsic in rig.extrinsics]
    result = ClassicalBackbone(densify=False).reconstruct(images)
    assert any("is a guess" in warning for warning in result.warnings)
    by_pair = {(p.first, p.second): p for p in result.pair_confidence}
    assert "guessed distance" in by_pair[(1, 3)].uncertain_reason
    motion = pair_motion(result, (1, 3))
    assert not motion.described and "guessed distance" in motion.reason
    # Pairs that measure their own direction still get their motion.
    measured = [p for p in result.pair_confidence if p.inliers >= 15 and p.uncertain_reason is None]
    assert measured and all(pair_motion(result, (p.first, p.second)).described for p in measured)
