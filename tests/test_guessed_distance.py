"""A view placed at a guessed distance flags the pairs whose direction may rest on the guess
(services/recon/backbones/classical/pair_uncertainty.py: flag_guessed_distances)."""

from __future__ import annotations

from itertools import combinations

import numpy as np

from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.intrinsics import guess_intrinsics
from services.recon.backbones.classical.pair_uncertainty import flag_guessed_distances
from services.recon.scene_motion import pair_motion
from shared.geometry.reconstruction import PairConfidence
from tests.support.scenes import rig_photos
from tests.support.stack import classical_recon, upload_photos


def _among_photos() -> list[np.ndarray]:
    """The synthetic "among" rig that answered wrong before: views 2 and 4 face each other and
    share no feature; view 4 is placed at a guessed distance from view 1."""
    return rig_photos(3, 17, "among", guess_intrinsics(320, 240, 80.0))[2]


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
    """Before the flag, the direction from view 2 to view 4 of _among_photos came out 33 degrees
    off, unflagged."""
    result = ClassicalBackbone(densify=False).reconstruct(_among_photos())
    assert any("is a guess" in warning for warning in result.warnings)
    by_pair = {(p.first, p.second): p for p in result.pair_confidence}
    assert "guessed distance" in by_pair[(1, 3)].uncertain_reason
    motion = pair_motion(result, (1, 3))
    assert not motion.described and "guessed distance" in motion.reason
    # Pairs that measure their own direction still get their motion.
    measured = [p for p in result.pair_confidence if p.inliers >= 15 and p.uncertain_reason is None]
    assert measured and all(pair_motion(result, (p.first, p.second)).described for p in measured)


def test_camera_motion_over_http_gives_no_motion_for_a_pair_resting_on_a_guessed_distance(
    tmp_path, redis_url
):
    with classical_recon(tmp_path, redis_url) as client:
        photos = _among_photos()
        scene_id = upload_photos(client, photos)
        pairs = client.reconstruct(scene_id).pairs
        response = client.camera_motion(scene_id, pairs=list(combinations(range(1, len(photos) + 1), 2)))
    by_pair = {(m.from_view, m.to_view): m for m in response.motions}  # views numbered from 1
    guessed = by_pair[(2, 4)]
    assert not guessed.described and "guessed distance" in guessed.reason
    assert guessed.direction is None and guessed.turn is None and guessed.over_focal is None
    assert guessed.sentence == f"From view 2 to view 4 the camera motion is unknown: {guessed.reason}."
    flagged = {(p.first, p.second): p.uncertain_reason for p in pairs}
    assert "guessed distance" in flagged[(2, 4)]
    # A pair that measures its own direction, in the same scene, still gets its sentence.
    measured = [(p.first, p.second) for p in pairs if p.inliers >= 15 and p.uncertain_reason is None]
    assert measured
    for pair in measured:
        assert by_pair[pair].described and by_pair[pair].reason is None
        assert by_pair[pair].sentence.startswith(f"From view {pair[0]} to view {pair[1]}")
        assert "unknown" not in by_pair[pair].sentence
