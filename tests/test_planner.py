"""The offline planner: question families, view parsing, and its programs run in the real sandbox.

The sandbox runs are served by `ColourRoomTools`, a scene of known geometry: four coloured walls of
points around the origin (world z up): red to the north (+y), green to the east, blue to the south,
yellow to the west. Facing north, behind a camera is blue, on its left yellow, on its right green.
Camera-motion sentences come from shared.geometry.camera_motion and renders from
shared.geometry.rendering, the code the recon service runs; only the reconstruction is given (exact
cameras and points, as a posed-RGB-D backbone would produce), so no recon service is needed.
"""

from __future__ import annotations

import ast

import numpy as np
import pytest

from services.agent.answering import answer_offline
from services.agent.planner import PlanningError, plan_intent, view_references
from services.agent.sandbox import run_program, validate_program
from shared.geometry.camera_motion import describe_camera_motion
from shared.geometry.reconstruction import Reconstruction
from shared.geometry.rendering import synthesize_novel_view
from shared.imaging.codecs import decode_image, encode_image
from shared.questions.intent import parse_question
from shared.synthetic.render import default_intrinsic, look_at

WORLD_UP = np.array([0.0, 0.0, 1.0])
WALL_COLOURS = {
    "red": (np.array([0.0, 1.0, 0.0]), (220, 30, 30)),
    "green": (np.array([1.0, 0.0, 0.0]), (30, 200, 30)),
    "blue": (np.array([0.0, -1.0, 0.0]), (30, 30, 220)),
    "yellow": (np.array([-1.0, 0.0, 0.0]), (230, 220, 30)),
}
EYE_HEIGHT = 1.5
IMAGE_SIZE = (64, 48)


def _wall(normal_direction: np.ndarray, colour: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """A 6 m wide, 3 m high grid of points 3 m from the origin, facing it."""
    across = np.cross(WORLD_UP, normal_direction)
    offsets, heights = np.meshgrid(np.linspace(-3, 3, 61), np.linspace(0, 3, 31))
    points = 3.0 * normal_direction + offsets.reshape(-1, 1) * across + heights.reshape(-1, 1) * WORLD_UP
    return points, np.tile(np.array(colour, dtype=np.uint8), (len(points), 1))


def camera(position_xy: tuple[float, float], heading_deg: float) -> np.ndarray:
    """Extrinsic of a level camera at `position_xy` facing `heading_deg` (0 = north, 90 = east)."""
    eye = np.array([position_xy[0], position_xy[1], EYE_HEIGHT])
    heading = np.radians(heading_deg)
    target = eye + np.array([np.sin(heading), np.cos(heading), 0.0])
    return look_at(eye, target, WORLD_UP)


class ColourRoomTools:
    """A `ToolProvider` (services.agent.sandbox) for the colour room seen by the given cameras."""

    def __init__(self, extrinsics: list[np.ndarray]) -> None:
        walls = [_wall(direction, colour) for direction, colour in WALL_COLOURS.values()]
        width, height = IMAGE_SIZE
        self.recon = Reconstruction(
            points=np.concatenate([points for points, _ in walls]),
            colors=np.concatenate([colours for _, colours in walls]),
            extrinsics=np.stack(extrinsics),
            intrinsics=np.stack([default_intrinsic(width, height)] * len(extrinsics)),
            image_sizes=np.array([IMAGE_SIZE] * len(extrinsics)),
            registered=np.ones(len(extrinsics), dtype=bool),
            backbone="colour-room",
            backbone_version="1",
        )

    def reconstruct(self) -> dict:
        return {
            "extrinsics": self.recon.extrinsics.tolist(),
            "intrinsics": self.recon.intrinsics.tolist(),
            "image_sizes": self.recon.image_sizes.tolist(),
            "registered": self.recon.registered.tolist(),
            "up": WORLD_UP.tolist(),
        }

    def describe_camera_motion(self, pair: tuple[int, int] | None = None) -> list[str]:
        pairs = [(pair[0] - 1, pair[1] - 1)] if pair else None
        motions = describe_camera_motion(self.recon.extrinsics, pairs=pairs, up=WORLD_UP)
        return [motion.sentence for motion in motions]

    def synthesize_novel_view(self, extrinsic: list[list[float]], width: int, height: int) -> bytes:
        rgb = synthesize_novel_view(self.recon, np.asarray(extrinsic), width, height)
        return encode_image(rgb, "png")

    def input_image(self, index: int) -> bytes:
        width, height = IMAGE_SIZE
        rgb = synthesize_novel_view(self.recon, self.recon.extrinsics[index], width, height)
        return encode_image(rgb, "png")


def dominant_wall(png: bytes) -> str:
    """The wall colour covering most non-background pixels of a rendered PNG."""
    rgb = decode_image(png, max_bytes=2**26, max_pixels=2**24).reshape(-1, 3).astype(np.int32)
    painted = rgb[rgb.sum(axis=1) < 3 * 245]  # renders are on white
    names = list(WALL_COLOURS)
    palette = np.array([colour for _, colour in WALL_COLOURS.values()])
    nearest = np.argmin(((painted[:, None, :] - palette[None]) ** 2).sum(axis=2), axis=1)
    counts = np.bincount(nearest, minlength=len(names))
    return names[int(np.argmax(counts))]


# ---- planning ------------------------------------------------------------------------------------


def planned(question: str, num_images: int = 4):
    plan = plan_intent(parse_question(question, num_images), num_images)
    validate_program(plan.source)  # the real sandbox validator
    ast.parse(plan.source)
    return plan


@pytest.mark.parametrize(
    ("question", "num_images", "views"),
    [
        ("From image 3, what is behind me?", 4, [3]),
        ("Looking from the third image, what is behind me?", 4, [3]),
        ("In view 2 and view 4, which chair is nearer?", 4, [2, 4]),
        ("Between picture 1 and picture 3, how did I move?", 4, [1, 3]),
        ("Compare photo #2 with Image4.", 4, [2, 4]),
        ("Views 1 and 3: how did I rotate?", 4, [1, 3]),
        ("From the first view to the second view", 4, [1, 2]),
        ("From the 2nd photo to the last photo", 5, [2, 5]),
        ("What is behind me?", 4, []),
    ],
)
def test_view_references(question: str, num_images: int, views: list[int]) -> None:
    assert view_references(question, num_images) == views


MINDCUBE_MOTION = (
    "Based on these two views showing the same scene: in which direction did I move from the first view "
    "to the second view? A. Diagonally forward and right B. Left C. Forward D. Backward"
)


def test_motion_consecutive_pair_uses_describe_camera_motion() -> None:
    plan = planned(MINDCUBE_MOTION, 2)
    assert plan.family == "motion" and plan.views == [1, 2]
    assert "pySpatial.describe_camera_motion(recon, 1, 2)" in plan.source


@pytest.mark.parametrize(
    ("question", "views", "indices"),
    [
        ("How did the camera move from view 1 to view 3? A. Left B. Right", [1, 3], (0, 2)),
        ("Which way did I walk from image 4 to image 2? A. Left B. Right", [4, 2], (3, 1)),
        ("From the first picture to the last picture, how did I turn? A. left B. right", [1, 4], (0, 3)),
    ],
)
def test_motion_other_pairs_name_the_pair(question: str, views: list[int], indices: tuple[int, int]) -> None:
    plan = planned(question, 4)
    assert plan.family == "motion" and plan.views == views
    assert f"pySpatial.describe_camera_motion(recon, {views[0]}, {views[1]})" in plan.source


def test_motion_needs_two_images() -> None:
    assert planned("How did I move? A. Left B. Right", 1).family != "motion"


@pytest.mark.parametrize(
    ("question", "family", "index", "operation"),
    [
        ("From image 3, what is behind me? A. A sofa B. A TV", "behind", 2, "pySpatial.turn_around(pose)"),
        ("Standing at view 2, what is at my back?", "behind", 1, "pySpatial.turn_around(pose)"),
        ("From the second picture, what is on my left?", "left", 1, "pySpatial.rotate_left(pose, angle=90)"),
        ("What is to your left in photo 4?", "left", 3, "pySpatial.rotate_left(pose, angle=90)"),
        ("In image 1, which object is on my right?", "right", 0, "pySpatial.rotate_right(pose, angle=90)"),
        ("What is behind me? A. x B. y", "behind", 0, "pySpatial.turn_around(pose)"),
    ],
)
def test_surroundings(question: str, family: str, index: int, operation: str) -> None:
    plan = planned(question)
    assert plan.family == family
    assert f"pose = recon.extrinsics[{index}]" in plan.source
    assert operation in plan.source and "synthesize_novel_view" in plan.source


def test_options_do_not_change_the_family() -> None:
    plan = planned("From image 2, what is behind me? A. It is to my left B. It is on my right C. Nothing")
    assert plan.family == "behind"


def test_turn_and_move_composes_the_steps_in_order() -> None:
    question = (
        "If I stand where image 2 was taken, turn right and walk forward, will the table be closer to me "
        "than the chair? A. Yes B. No"
    )
    plan = planned(question)
    assert plan.family == "turn_and_move" and plan.views == [2]
    lines = [line.strip() for line in plan.source.splitlines()]
    turn = lines.index("pose = pySpatial.rotate_right(pose, angle=90)")
    before = lines.index("before = pySpatial.synthesize_novel_view(recon, pose)")
    move = lines.index("pose = pySpatial.move_forward(pose)")
    after = lines.index("after = pySpatial.synthesize_novel_view(recon, pose)")
    assert lines.index("pose = recon.extrinsics[1]  # view 2") < turn < before < move < after


def test_turn_and_move_with_angles_and_distances() -> None:
    question = (
        "Standing where image 3 was taken and facing the same way, you turn left by 45 degrees and walk "
        "forward 1 meter, then turn around. Will you be closer to the sofa? A. closer B. farther"
    )
    plan = planned(question)
    assert plan.family == "turn_and_move"
    steps = [line.strip() for line in plan.source.splitlines() if line.strip().startswith("pose = pySpatial")]
    assert steps == [
        "pose = pySpatial.rotate_left(pose, angle=45)",
        "pose = pySpatial.move_forward(pose, distance=1)",
        "pose = pySpatial.turn_around(pose)",
    ]


def test_after_turning_counts_as_a_move_to_make() -> None:
    plan = planned("From view 1, after turning 90 degrees to the right, what is in front of me? A. x B. y")
    assert plan.family == "turn_and_move"
    assert "pySpatial.rotate_right(pose, angle=90)" in plan.source


def test_other_questions_render_around_the_asked_view() -> None:
    plan = planned("Which object is closest to the lamp in image 2? A. chair B. sofa")
    assert plan.family == "around" and plan.views == [2]
    for operation in ("rotate_left(pose, angle=90)", "rotate_right(pose, angle=90)", "turn_around(pose)"):
        assert operation in plan.source


def test_a_view_that_does_not_exist_is_an_error() -> None:
    with pytest.raises(PlanningError, match="view 5, but there are 3 image"):
        plan_intent(parse_question("From image 5, what is behind me?", 3), 3)
    with pytest.raises(PlanningError):
        plan_intent(parse_question("anything", 0), 0)


# ---- running the plans in the sandbox --------------------------------------------------------------

ROOM = [camera((0.0, 0.0), 0.0), camera((0.5, 0.8), -45.0), camera((-1.0, -0.5), 90.0)]


@pytest.fixture(scope="module")
def tools() -> ColourRoomTools:
    return ColourRoomTools(ROOM)


def run(question: str, tools: ColourRoomTools):
    plan = plan_intent(parse_question(question, len(ROOM)), len(ROOM))
    result = run_program(plan.source, question, len(ROOM), tools)
    assert result.ok, result.error
    return plan, result


@pytest.mark.parametrize(
    ("question", "walls"),
    [
        ("From image 1, what is behind me?", ["blue"]),
        ("From image 1, what is on my left?", ["yellow"]),
        ("From image 1, what is on my right?", ["green"]),
        ("From image 3, what is behind me?", ["yellow"]),  # image 3 faces east
        ("What can be seen around image 1?", ["yellow", "green", "blue"]),  # left, right, behind
        ("If I stand at image 1 and turn left, what do I face?", ["red", "yellow"]),  # before, after
    ],
)
def test_rendered_clues_show_the_asked_side(question: str, walls: list[str], tools: ColourRoomTools) -> None:
    _, result = run(question, tools)
    assert [dominant_wall(png) for png in result.clue_images] == walls


class MetricColourRoom(ColourRoomTools):
    """The colour room as a metric reconstruction reports it (units: metres)."""

    def reconstruct(self) -> dict:
        return {**super().reconstruct(), "units": "metres"}


@pytest.mark.parametrize("metric", [True, False])
def test_a_distance_in_metres_is_moved_only_where_the_scene_is_metric(metric: bool) -> None:
    """'Walk 2.5 m' from the origin facing north ends 0.5 m from the red wall: in a metric scene the
    render after it is all red; without a metric scale the program says why it cannot move metres."""
    question = "From image 1, if you walk forward 2.5 meters, what is in front of you? A. a wall B. a door"
    room = MetricColourRoom(ROOM) if metric else ColourRoomTools(ROOM)
    plan = plan_intent(parse_question(question, len(ROOM)), len(ROOM))
    result = run_program(plan.source, question, len(ROOM), room)
    if metric:
        assert result.ok and [dominant_wall(png) for png in result.clue_images] == ["red"]
        assert "no metric scale" not in (result.clue_text or "")
    else:
        assert result.clue_images == [] and "no metric scale" in (result.clue_text or result.error or "")


def test_computed_motion_matches_shared_camera_motion(tools: ColourRoomTools) -> None:
    _, result = run("How did the camera move from view 1 to view 3? A. Left B. Right", tools)
    expected = describe_camera_motion(tools.recon.extrinsics, pairs=[(0, 2)], up=WORLD_UP)[0].sentence
    assert result.clue_text == expected
    reverse = run("How did the camera move from view 3 to view 1? A. Left B. Right", tools)[1]
    assert (
        reverse.clue_text
        == describe_camera_motion(tools.recon.extrinsics, pairs=[(2, 0)], up=WORLD_UP)[0].sentence
    )


@pytest.mark.parametrize(
    ("question", "answer"),
    [
        (
            "In which direction did I move from the first view to the second view? "
            "A. Diagonally back and left B. Forward-right C. Left D. Forward",
            "B",
        ),
        ("How did the camera move from view 2 to view 3? A. Right B. Forward C. Left D. Back", "C"),
        ("How did the camera move from view 1 to view 3? A. back-left B. front-left C. back-right", "A"),
        (
            "How did I turn from view 1 to view 2? A. turned right by about 45 degrees "
            "B. turned left by about 45 degrees C. turned left by about 90 degrees D. did not turn",
            "B",
        ),
    ],
)
def test_planned_motion_programs_answer_offline(question: str, answer: str, tools: ColourRoomTools) -> None:
    _, result = run(question, tools)
    assert answer_offline(parse_question(question), result.clue_text, result.clue_images).answer == answer
