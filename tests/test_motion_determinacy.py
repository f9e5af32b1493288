"""Camera motion over an unknown focal: which words every field-of-view hypothesis shares.

The pure rules on hand-made hypotheses, the store/load of hypotheses (reconstruction format 5, older
files still read), and the classical backbone on real photos with the focal withheld.
"""

from __future__ import annotations

import numpy as np
import pytest

from shared.geometry.motion_determinacy import FocalHypotheses, PairHypotheses, motion_over_focal
from shared.geometry.poses import axis_angle_matrix
from shared.geometry.reconstruction import Reconstruction
from tests.test_reconstruction import sample

# Every quantity of the motion vocabulary that is read over the focal hypotheses.
QUANTITIES = {"turn", "tilt", "roll", "direction", "lateral", "depth", "vertical", "still"}
_DOWN = np.array([0.0, 1.0, 0.0])  # camera +y points down: a turn about it is a yaw


def _hypotheses(yaws_deg: list[float], steps: list[list[float]]) -> PairHypotheses:
    """A pair at fields of view 30, 40, ...: turned by `yaws_deg` (+ = left), stepped by `steps`."""
    rotations, translations = [], []
    for yaw, step in zip(yaws_deg, steps, strict=True):
        # Camera 2's axes in camera 1's: a left turn is a rotation about -y (up) by +yaw.
        orientation = axis_angle_matrix(-_DOWN, yaw)
        rotation = orientation.T  # x_second = R^T (x_first - centre)
        centre = np.asarray(step, float) / np.linalg.norm(step)
        rotations.append(rotation.tolist())
        translations.append((-rotation @ centre).tolist())
    fovs = [30.0 + 10 * k for k in range(len(yaws_deg))]
    return PairHypotheses(0, 1, fovs, rotations, translations, [100] * len(fovs))


def test_a_turn_that_holds_at_every_focal_is_determined_and_a_step_that_varies_is_not():
    # The hand check: left by 12-42 degrees at every FOV; the step swings forward-left.
    motion = motion_over_focal(
        _hypotheses([12, 25, 42], [[0.0, 0.0, 1.0], [-0.3, 0.0, 1.0], [-1.0, 0.0, 1.0]])
    )
    assert motion.turn_determined and motion.turns == ["left"]
    assert motion.yaw_range_deg == pytest.approx((12.0, 42.0), abs=1e-6)
    assert not motion.direction_determined
    assert motion.directions == ["forward", "diagonally forward and left"]
    assert motion.fov_range_deg == (30.0, 50.0) and motion.hypotheses == 3
    assert motion.sentence.startswith(
        "From view 1 to view 2 the camera turned left by 12 to 42 degrees (determined) and moved "
        "forward or diagonally forward and left (not determined; heading 0 to 45 degrees, 0 = forward, "
        "+ = left)"
    )
    assert motion.heading_range_deg == pytest.approx((-45.0, 0.0), abs=1e-6)
    np.testing.assert_allclose(motion.translation_directions[0], [0.0, 0.0, 1.0], atol=1e-9)


def test_a_turn_that_changes_side_over_the_focal_range_is_not_determined():
    motion = motion_over_focal(_hypotheses([-15, 3, 20], [[1.0, 0.0, 0.0]] * 3))
    assert not motion.turn_determined and motion.turns == ["right", "none", "left"]
    assert motion.direction_determined and motion.directions == ["right"]
    assert "turned between 15 degrees right and 20 degrees left (not determined)" in motion.sentence
    assert "moved right (determined; heading -90 to -90 degrees" in motion.sentence


def test_reversed_pair_turns_the_other_way():
    pair = _hypotheses([12, 42], [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    stored = FocalHypotheses([30.0, 40.0, 50.0], 40.0, [pair])
    back = motion_over_focal(stored.for_pair(1, 0))
    assert back.turns == ["right"] and back.yaw_range_deg == pytest.approx((-42.0, -12.0), abs=1e-6)
    # Seen from view 2, view 1 is behind, and behind-left once view 2 has turned 42 degrees.
    assert back.directions == ["backward", "diagonally back and left"]
    assert stored.for_pair(0, 2) is None


def test_hypotheses_are_stored_and_read_back_and_older_files_have_none():
    recon = sample(num_points=20, with_depth=False)
    recon.focal_hypotheses = FocalHypotheses(
        [10.0, 20.0, 30.0], 20.0, [_hypotheses([12, 42], [[0.0, 0.0, 1.0], [-1.0, 0.0, 1.0]])]
    )
    restored = Reconstruction.from_bytes(recon.to_bytes())
    assert restored.focal_hypotheses == recon.focal_hypotheses
    assert Reconstruction.from_bytes(sample(num_points=20).to_bytes()).focal_hypotheses is None


# ---- the agent answers only what every hypothesis agrees on ---------------------------------------

_ASKS = "Based on these two images (image 1 and 2) showing the same scene: "
_TURN_QUESTION = (
    "Based on these two images (image 1 and 2) showing the same scene: How did I turn from image 1 to "
    "image 2? A. turned left by about 45 degrees B. turned right by about 45 degrees C. did not turn"
)
_MOVE_QUESTION = (
    "Based on these two images (image 1 and 2) showing the same scene: How did I move from image 1 to "
    "image 2? A. forward B. left C. diagonally forward and left D. backward"
)


def test_the_agent_answers_a_choice_that_holds_at_every_focal_and_refuses_one_that_does_not():
    from services.agent.answering import UNDETERMINED, answer_offline
    from shared.questions.intent import parse_question

    # Left by 30 to 60 degrees at every focal: "left by about 45" is the nearest option throughout.
    left = motion_over_focal(_hypotheses([30, 45, 60], [[-0.3, 0.0, 1.0]] * 3))
    turned = answer_offline(parse_question(_TURN_QUESTION), left.sentence, [])
    assert turned.answer == "A", turned.reasoning
    # The step swings from forward to forward-left over the focal range: no answer, with the range.
    walked = answer_offline(
        parse_question(_MOVE_QUESTION),
        motion_over_focal(
            _hypotheses([12, 25, 42], [[0.0, 0.0, 1.0], [-0.3, 0.0, 1.0], [-1.0, 0.0, 1.0]])
        ).sentence,
        [],
    )
    assert walked.answer is None
    assert UNDETERMINED in walked.reason and "12 to 42 degrees" in walked.reason
    assert "options A, C each fit" in walked.reason
    # A turn from 15 right to 20 left straddles three options: refused too.
    straddle = motion_over_focal(_hypotheses([-15, 3, 20], [[1.0, 0.0, 0.0]] * 3))
    refused = answer_offline(parse_question(_TURN_QUESTION), straddle.sentence, [])
    assert refused.answer is None and UNDETERMINED in refused.reason
    # The same step, determined, answers the move question.
    right = answer_offline(
        parse_question(_MOVE_QUESTION.replace("B. left", "B. right")), straddle.sentence, []
    )
    assert right.answer == "B", right.reasoning


def test_a_question_without_options_gets_only_the_determined_words():
    from services.agent.free_form import answer_offline
    from shared.questions.intent import parse_question

    ask = _ASKS + "How did I move from image 1 to image 2?"
    swinging = motion_over_focal(
        _hypotheses([12, 25, 42], [[0.0, 0.0, 1.0], [-0.3, 0.0, 1.0], [-1.0, 0.0, 1.0]])
    )
    result = answer_offline(parse_question(ask), swinging.sentence, [])
    assert result.answer == (
        "turned left by 12 to 42 degrees (the step cannot be determined from these photos: moved forward "
        "or diagonally forward and left, heading 0 to 45 degrees (0 = forward, + = left))"
    )
    straddle = motion_over_focal(_hypotheses([-15, 3, 20], [[1.0, 0.0, 0.0]] * 3))
    stepped = answer_offline(parse_question(ask), straddle.sentence, [])
    assert stepped.answer == (
        "moved right (the turn cannot be determined from these photos: turned between 15 degrees right "
        "and 20 degrees left)"
    )


# ---- every quantity over the focal range: tilt and roll too ---------------------------------------

_FOVS = [float(f) for f in range(10, 101, 5)]  # the backbone's grid: telephoto to wide angle
_WIDTH = 640.0


def _focal_px(fov_deg: float) -> float:
    return _WIDTH / 2 / np.tan(np.radians(fov_deg) / 2)


def _oriented(turn: float, tilt: float, roll: float, step: list[float]) -> tuple[list, list]:
    """(R, t) of a second camera turned (+ left), then tilted (+ up), then rolled (+ clockwise) in its
    own axes, its centre at the unit `step` in the first camera's axes (x right, y down, z forward)."""
    orientation = (
        axis_angle_matrix(-_DOWN, turn)
        @ axis_angle_matrix(np.array([1.0, 0.0, 0.0]), tilt)
        @ axis_angle_matrix(np.array([0.0, 0.0, 1.0]), roll)
    )
    rotation = orientation.T
    centre = np.asarray(step, float) / np.linalg.norm(step)
    return rotation.tolist(), (-rotation @ centre).tolist()


def _over_grid(angles: list[tuple[float, float, float]], step: list[float]) -> PairHypotheses:
    rotations, translations = zip(*(_oriented(*angle, step) for angle in angles), strict=True)
    return PairHypotheses(0, 1, list(_FOVS), list(rotations), list(translations), [80] * len(_FOVS))


def _tilt_of_shift(shift_px: float) -> list[tuple[float, float, float]]:
    """What view 1's image centre, seen `shift_px` pixels lower in view 2, makes of the tilt at each
    field of view: the same pixels are a small angle at telephoto and a large one at wide angle."""
    return [(0.0, float(np.degrees(np.arctan(shift_px / _focal_px(fov)))), 0.0) for fov in _FOVS]


_DOWN_STEP = [0.0, 1.0, 0.2]  # mostly down in view 1's image, as around templeRing


def test_a_tilt_that_holds_from_10_to_100_degrees_fov_is_determined_with_its_range():
    # 400 px on a 640 px wide photo: 6.2 degrees up at a 10-degree FOV, 56 degrees at 100.
    motion = motion_over_focal(_over_grid(_tilt_of_shift(400.0), _DOWN_STEP))
    tilt = motion.quantities["tilt"]
    assert tilt.determined and tilt.words == ["up"]
    assert tilt.range == pytest.approx((6.24, 56.13), abs=0.01)
    assert motion.fov_range_deg == (10.0, 100.0) and motion.hypotheses == 19
    for name in ("turn", "roll", "vertical", "depth", "lateral", "direction", "still"):
        assert motion.quantities[name].determined, name
    assert motion.quantities["vertical"].words == ["down"] and motion.vertical_determined
    assert motion.quantities["turn"].words == ["none"] and motion.quantities["roll"].words == ["none"]
    assert motion.quantities["depth"].words == ["none"] and motion.quantities["still"].words == ["moved"]
    assert "; it moved down (determined); it tilted up by 6 to 56 degrees (determined); it did not roll " in (
        motion.sentence
    )
    assert set(motion.to_dict()["quantities"]) == QUANTITIES


def test_a_tilt_that_crosses_the_threshold_inside_the_fov_range_is_not_determined():
    # 150 px: 2.3 degrees (no tilt) at a 10-degree FOV, 29 degrees up at 100.
    motion = motion_over_focal(_over_grid(_tilt_of_shift(150.0), _DOWN_STEP))
    tilt = motion.quantities["tilt"]
    assert not tilt.determined and tilt.words == ["none", "up"]
    assert tilt.range == pytest.approx((2.35, 29.19), abs=0.01)
    assert motion.quantities["vertical"].determined and motion.quantities["turn"].determined
    assert "it tilted between 2 degrees up and 29 degrees up (not determined)" in motion.sentence


def test_a_roll_is_determined_when_it_holds_at_every_focal_and_not_when_it_changes_side():
    # A roll about the viewing direction turns the photo by the same angle at every focal.
    rolled = motion_over_focal(_over_grid([(0.0, 0.0, 20.0)] * len(_FOVS), [1.0, 0.0, 0.0]))
    roll = rolled.quantities["roll"]
    assert roll.determined and roll.words == ["clockwise"] and roll.range == pytest.approx((20.0, 20.0))
    assert rolled.quantities["tilt"].determined and rolled.quantities["tilt"].words == ["none"]
    assert "it rolled clockwise by about 20 degrees (determined)" in rolled.sentence
    # One that goes from 4 degrees counterclockwise to 12 clockwise over the range is not.
    spread = [(0.0, 0.0, -4.0 + 16.0 * k / (len(_FOVS) - 1)) for k in range(len(_FOVS))]
    swinging = motion_over_focal(_over_grid(spread, [1.0, 0.0, 0.0]))
    roll = swinging.quantities["roll"]
    assert not roll.determined and roll.words == ["none", "clockwise"]
    assert roll.range == pytest.approx((-4.0, 12.0))
    assert "it rolled between 4 degrees counterclockwise and 12 degrees clockwise (not determined)" in (
        swinging.sentence
    )
    assert swinging.quantities["lateral"].words == ["right"] and swinging.quantities["lateral"].determined


_TILT_QUESTION = (
    _ASKS + "Which way did the camera tilt from image 1 to image 2? A. Up B. Down C. It did not tilt"
)
_ROLL_QUESTION = _ASKS + (
    "How did the camera rotate from image 1 to image 2? A. rolled clockwise B. rolled counterclockwise "
    "C. did not rotate"
)
_UPDOWN_QUESTION = "Which way did the camera move from image 1 to image 2? A. Left B. Right C. Up D. Down"


def test_the_agent_answers_a_tilt_or_roll_only_when_every_focal_gives_it():
    from services.agent.answering import UNDETERMINED, answer_offline
    from shared.questions.intent import parse_question

    tilted = motion_over_focal(_over_grid(_tilt_of_shift(400.0), _DOWN_STEP)).sentence
    answer = answer_offline(parse_question(_TILT_QUESTION), tilted, [])
    assert answer.answer == "A", answer.reason
    # The step is down at every focal too: the bare "Down" of a movement question is it.
    moved = answer_offline(parse_question(_UPDOWN_QUESTION), tilted, [])
    assert moved.answer == "D", moved.reason
    crossing = motion_over_focal(_over_grid(_tilt_of_shift(150.0), _DOWN_STEP)).sentence
    refused = answer_offline(parse_question(_TILT_QUESTION), crossing, [])
    assert refused.answer is None and UNDETERMINED in refused.reason
    assert "tilted between 2 degrees up and 29 degrees up (not determined)" in refused.reason
    assert "options A, C each fit some of them" in refused.reason
    # The step does not depend on the tilt: still "Down".
    assert answer_offline(parse_question(_UPDOWN_QUESTION), crossing, []).answer == "D"

    rolled = motion_over_focal(_over_grid([(0.0, 0.0, 20.0)] * len(_FOVS), [1.0, 0.0, 0.0])).sentence
    assert answer_offline(parse_question(_ROLL_QUESTION), rolled, []).answer == "A"
    spread = [(0.0, 0.0, -4.0 + 16.0 * k / (len(_FOVS) - 1)) for k in range(len(_FOVS))]
    swinging = motion_over_focal(_over_grid(spread, [1.0, 0.0, 0.0])).sentence
    refused = answer_offline(parse_question(_ROLL_QUESTION), swinging, [])
    assert refused.answer is None and UNDETERMINED in refused.reason
    assert "rolled between 4 degrees counterclockwise and 12 degrees clockwise" in refused.reason


def test_free_form_tilt_and_roll_say_the_range_only_when_determined():
    from services.agent.free_form import answer_offline
    from shared.questions.intent import parse_question

    tilt_ask = parse_question(_ASKS + "How did the camera tilt from image 1 to image 2?")
    tilted = motion_over_focal(_over_grid(_tilt_of_shift(400.0), _DOWN_STEP)).sentence
    assert answer_offline(tilt_ask, tilted, []).answer == "tilted up by 6 to 56 degrees"
    move_ask = parse_question(_ASKS + "How did the camera move from image 1 to image 2?")
    assert answer_offline(move_ask, tilted, []).answer == "moved down, tilted up by 6 to 56 degrees"
    crossing = motion_over_focal(_over_grid(_tilt_of_shift(150.0), _DOWN_STEP)).sentence
    refused = answer_offline(tilt_ask, crossing, [])
    assert refused.answer is None and "cannot be determined from these photos" in refused.reason
    assert answer_offline(move_ask, crossing, []).answer == (
        "moved down (the tilt cannot be determined from these photos: tilted between 2 degrees up and "
        "29 degrees up)"
    )
    roll_ask = parse_question(_ASKS + "How did the camera roll from image 1 to image 2?")
    rolled = motion_over_focal(_over_grid([(0.0, 0.0, 20.0)] * len(_FOVS), [1.0, 0.0, 0.0])).sentence
    assert answer_offline(roll_ask, rolled, []).answer == "rolled clockwise by about 20 degrees"


def test_older_sentences_without_tilt_or_roll_never_answer_them():
    from services.agent.answering import answer_offline
    from shared.questions.intent import parse_question

    older = (
        "From view 1 to view 2 the camera turned left by 12 to 42 degrees (determined) and moved forward "
        "(determined; heading -5 to 5 degrees, 0 = forward, + = left), over every horizontal field of "
        "view the photos allow (30 to 50 degrees; the focal length is unknown)."
    )
    assert answer_offline(parse_question(_TILT_QUESTION), older, []).answer is None
    turned = parse_question(_TURN_QUESTION.replace("about 45", "about 30"))
    assert answer_offline(turned, older, []).answer == "A"


# ---- through HTTP: /v1/camera-motion and /v1/solve on a stored reconstruction of unknown focal -----


def _stored_over_grid(hypotheses: PairHypotheses) -> Reconstruction:
    """Two views as the classical backbone stores them when the focal is unknown: the poses of the
    central hypothesis (55 degrees) flagged as resting on it, and every pair's hypotheses."""
    from services.recon.backbones.classical import ClassicalBackbone
    from shared.geometry.motion_determinacy import FOCAL_HYPOTHESIS_REASON
    from shared.geometry.reconstruction import ViewConfidence

    central = _FOVS.index(55.0)
    second = np.concatenate(
        [np.asarray(hypotheses.rotations[central]), np.asarray(hypotheses.translations[central])[:, None]], 1
    )
    first = np.concatenate([np.eye(3), np.zeros((3, 1))], 1)
    focal = _focal_px(55.0)
    intrinsic = np.array([[focal, 0.0, 319.5], [0.0, focal, 239.5], [0.0, 0.0, 1.0]])
    rng = np.random.default_rng(3)
    points = rng.normal(size=(200, 3)) + np.array([0.0, 0.0, 6.0])
    flagged = ViewConfidence(uncertain_reason=f"{FOCAL_HYPOTHESIS_REASON} (55 degrees of 10 to 100)")
    return Reconstruction(
        points=points,
        colors=rng.integers(0, 256, (200, 3)),
        extrinsics=np.stack([first, second]),
        intrinsics=np.stack([intrinsic, intrinsic]),
        image_sizes=[(640, 480)] * 2,
        registered=[True, True],
        backbone="classical",
        backbone_version=ClassicalBackbone.version,
        view_confidence=[flagged, flagged],
        focal_hypotheses=FocalHypotheses(list(_FOVS), 55.0, [hypotheses]),
    )


def test_camera_motion_and_solve_over_http_say_per_quantity_what_every_focal_gives(tmp_path, redis_url):
    import uuid

    import httpx
    import redis

    from services.recon.camera_inputs import INPUTS_VERSION
    from shared.imaging.codecs import encode_image
    from shared.local.services import running_service
    from shared.wire.client import AgentClient, ReconClient

    namespace = f"test-{uuid.uuid4().hex[:8]}"  # its own cache keys on the shared test Redis
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path),
        "PYSPATIAL_BACKBONE": "classical",
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": namespace,
    }
    photos = [encode_image(np.full((480, 640, 3), shade, np.uint8)) for shade in (90, 160)]
    stored = _stored_over_grid(_over_grid(_tilt_of_shift(400.0), _DOWN_STEP))
    with running_service("services.recon.app:create_app", env) as service:
        with ReconClient(service.url, timeout=60) as client:
            scene_id = client.upload_scene(photos).scene_id
            # The reconstruction the backbone would store for these photos, under its cache key.
            version = f"{stored.backbone_version}:in{INPUTS_VERSION}"
            key = f"pyspatial:{namespace}:recon:{scene_id}:classical:{version}"
            redis.Redis.from_url(redis_url).set(key, stored.to_bytes(), ex=600)
            response = httpx.post(service.url + "/v1/camera-motion", json={"scene_id": scene_id}, timeout=60)
            agent_env = {"PYSPATIAL_RECON_URL": service.url, "PYSPATIAL_SANDBOX_WALL_S": "60"}
            with running_service("services.agent.app:create_app", agent_env) as agent:
                with AgentClient(agent.url, timeout=120) as asker:
                    tilted = asker.solve(_TILT_QUESTION, scene_id=scene_id)
                    moved = asker.solve(_UPDOWN_QUESTION, scene_id=scene_id)
    assert response.status_code == 200, response.text
    [motion] = response.json()["motions"]
    over = motion["over_focal"]
    assert over["frame"] == "image" and over["hypotheses"] == 19 and over["fov_range_deg"] == [10.0, 100.0]
    assert set(over["quantities"]) == QUANTITIES
    tilt = over["quantities"]["tilt"]
    assert tilt["determined"] and tilt["words"] == ["up"]
    assert tilt["range"] == pytest.approx([6.24, 56.13], abs=0.01)
    assert over["quantities"]["vertical"] == {
        "words": ["down"],
        "range": pytest.approx([-0.981, -0.981], abs=1e-3),
        "determined": True,
    }
    assert (
        motion["sentence"] == over["sentence"]
        and "it tilted up by 6 to 56 degrees (determined)" in (motion["sentence"])
    )
    assert tilted.answer == "A", tilted.answer_reason
    assert moved.answer == "D", moved.answer_reason


def test_a_question_about_the_rooms_up_is_not_answered_from_image_axes_over_focal():
    # Rolled photos make the image's "down" anything in the room; over focal hypotheses only the
    # image axes are known, so "down in the room" stays unanswered.
    from services.agent import answering, free_form
    from shared.questions.intent import parse_question

    tilted = motion_over_focal(_over_grid(_tilt_of_shift(400.0), _DOWN_STEP)).sentence
    room = parse_question(_UPDOWN_QUESTION.replace("move from", "move, relative to the floor, from"))
    assert room.motion_frame == "gravity"
    refused = answering.answer_offline(room, tilted, [])
    assert refused.answer is None and "gravity frame" in refused.reason
    free = parse_question(_ASKS + "How did the camera move relative to the floor from image 1 to image 2?")
    assert free_form.answer_offline(free, tilted, []).answer is None
