"""Closed-loop execution of a route plan: stop where it says the floor is unseen, look, replan.

A plan that crosses floor no photo shows tells the robot to "go slowly and look again". Here the
simulated robot does that on the true geometry: it drives the plan's steps (left-positive turns
about +z, moves in metres) from its true pose; at the start of the first unseen stretch ahead it
stops, turns to face along that leg, takes a posed RGB-D look from its own camera (the scene's
camera height, the generator's pitch, intrinsics and image size; ``two_rooms.robot_view``,
rendered from the true scene), adds it to the views it has and replans from where it stands, the
new look being the start view (index 0: ``plan_route`` starts below the start view's camera and
takes its heading from it). A stretch that begins where the robot has just looked (the floor just
ahead of a camera pitched down is below its frame) is driven, up to ``LOOK_AGAIN_AFTER_M``; a longer
one is entered that far and looked at again. A refusal that says where to look (``look_next`` of an
``unseen_space`` refusal: no photo shows a way) is followed the same way: the robot drives its steps
(over floor the photos show), faces the unlooked space, looks and replans. After ``max_looks`` looks
the last plan is driven out, or its refusal stands.

Collisions are checked on the whole driven path: every executed move, before and after each look,
is sampled every ``step_m`` and the disc tested against the true footprints; a collision ends the
run there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from shared.geometry.backprojection import reconstruction_from_rgbd
from shared.navigation import Robot, plan_route
from shared.synthetic.render import render_view
from shared.synthetic.two_rooms import TwoRoomScene, disc_collides, drive, footprints, robot_view

_AT_HAND_M = 0.05  # a stretch beginning this close to the robot begins where it stands
LOOK_AGAIN_AFTER_M = 1.0  # a stretch that begins at the robot is entered this far before the next look
DEFAULT_LOOKS = 4


@dataclass
class LoopRun:
    """One closed-loop execution on the true geometry."""

    trace: np.ndarray  # (N, 2) every sampled robot centre along the whole driven path, in order
    end: np.ndarray  # (2,) where the robot stopped
    heading: float
    length: float  # metres driven
    collided: bool  # the disc at some sample of ``trace`` overlaps a true footprint
    looks: list[np.ndarray] = field(default_factory=list)  # (2,) where each new look was taken
    last_plan: object = None  # the last RoutePlan (a refusal when the run ended refused)
    # each plan made after a look, with the views it was made on (the look first)
    replans: list[tuple[object, list]] = field(default_factory=list)
    refused: bool = False


def _stretch_arcs(plan, position: np.ndarray, heading: float) -> list[tuple[float, float]]:
    """The plan's unseen stretches as (from, to) metres along its whole path, driven from the pose."""
    starts, along = [], 0.0
    for step in plan.steps:
        heading += np.radians(step["turn_degrees"])
        starts.append((position.copy(), along))
        position = position + step["move"] * np.array([np.cos(heading), np.sin(heading)])
        along += step["move"]
    arcs = []
    for stretch in plan.unseen_stretches:
        origin, offset = starts[stretch["step"] - 1]
        low = offset + float(np.linalg.norm(np.asarray(stretch["start_world"])[:2] - origin))
        arcs.append((low, low + float(stretch["length"])))
    return arcs


def next_stop(arcs: list[tuple[float, float]]) -> float | None:
    """Metres along the plan where the robot stops to look (None: drive it out)."""
    for low, high in arcs:
        if low > _AT_HAND_M:
            return low
        if high > LOOK_AGAIN_AFTER_M:
            return LOOK_AGAIN_AFTER_M
    return None


def _moves_up_to(plan, distance: float | None) -> list[tuple[float, float]]:
    """The plan's (turn, move) pairs cut at ``distance`` metres along it; at a step's start, the
    step's turn is kept (the robot faces the next leg to look along it)."""
    moves, along = [], 0.0
    for step in plan.steps:
        if distance is not None and along + step["move"] > distance:
            moves.append((step["turn_degrees"], max(distance - along, 0.0)))
            return moves
        moves.append((step["turn_degrees"], step["move"]))
        along += step["move"]
    return moves


def _recon(two: TwoRoomScene, views: list):
    return reconstruction_from_rgbd(
        [v.rgb for v in views],
        [v.depth for v in views],
        np.stack([v.extrinsic for v in views]),
        [two.intrinsic] * len(views),
    )


def closed_loop(
    two: TwoRoomScene,
    views: list,
    first_plan,
    robot: Robot,
    goal: np.ndarray,
    max_looks: int = DEFAULT_LOOKS,
    band: tuple[float, float] = (0.05, 0.5),
    step_m: float = 0.02,
) -> LoopRun:
    """Drive ``first_plan`` (made on ``views``, view 0 the start) from the true start pose,
    looking again where it crosses unseen floor, at most ``max_looks`` times."""
    polygons = footprints(two.solids, band)
    forward = two.extrinsics[0][2, :2]
    heading = float(np.arctan2(forward[1], forward[0]))
    position = two.start_floor()[:2].astype(np.float64)
    run = LoopRun(trace=position[None], end=position, heading=heading, length=0.0, collided=False)
    plan, views = first_plan, list(views)
    while True:
        run.last_plan = plan
        looks_left = len(run.looks) < max_looks
        if not plan.reachable and not (looks_left and plan.look_next):
            run.refused = True
            break
        if plan.reachable:
            stop = next_stop(_stretch_arcs(plan, position, heading)) if looks_left else None
            moves = _moves_up_to(plan, stop)
        else:  # no photo shows a way: go where the refusal says to look, and look
            stop = 0.0
            moves = [(step["turn_degrees"], step["move"]) for step in plan.look_next["steps"]]
        samples, position, heading, length = drive(position, heading, moves, step_m)
        run.trace = np.concatenate([run.trace, samples])
        run.length += length
        if disc_collides(samples, polygons, robot.radius).any() or stop is None:
            break
        look = render_view(two.scene, robot_view(two, position, heading), two.intrinsic, *two.size)
        views = [look, *views]
        run.looks.append(position.copy())
        plan = plan_route(_recon(two, views), 0, goal, robot=robot)
        run.replans.append((plan, views))
    run.end, run.heading = position, heading
    run.collided = bool(disc_collides(run.trace, polygons, robot.radius).any())  # the whole path
    return run


@dataclass
class LoopTally:
    """Outcomes of one way of executing plans (single-shot or closed loop) over a group of captures."""

    reachable: int = 0
    reached: int = 0
    collisions: int = 0
    refused_at_start: int = 0  # a reachable goal refused before moving
    refused_after_look: int = 0  # a reachable goal refused after the robot looked again
    short: int = 0  # ended farther than the tolerance from the goal, without a collision
    unreachable: int = 0
    refused_true: int = 0  # an unreachable goal's last plan refuses it with the true reason
    refused_other: int = 0
    driven_unreachable: int = 0  # an unreachable goal whose plan was driven out
    looks: int = 0
    runs_that_looked: int = 0
    replans_crossing: int = 0  # plans made after a look whose path crosses floor no view showed
    replans_said: int = 0  # ... of which the plan reports unseen_m > 0
    ratios: list[float] = field(default_factory=list)

    def add(self, kind: str, run: LoopRun, goal_xy, shortest, tolerance: float, true_reason: bool) -> str:
        """Count one run; its outcome in a word."""
        self.looks += len(run.looks)
        self.runs_that_looked += int(bool(run.looks))
        if kind != "reachable":
            self.unreachable += 1
            outcome = "refused" if run.refused else "driven"
            self.refused_true += int(run.refused and true_reason)
            self.refused_other += int(run.refused and not true_reason)
            self.driven_unreachable += int(not run.refused)
            return outcome
        self.reachable += 1
        if run.collided:
            self.collisions += 1
            return "collided"
        if run.refused:
            self.refused_after_look += int(bool(run.looks))
            self.refused_at_start += int(not run.looks)
            return "refused"
        if np.linalg.norm(run.end - np.asarray(goal_xy)[:2]) > tolerance:
            self.short += 1
            return "short"
        self.reached += 1
        self.ratios.append(run.length / shortest)
        return "reached"

    def cells(self) -> list[str]:
        ratios = self.ratios or [float("nan")]
        return [
            f"{self.reached}/{self.reachable}",
            str(self.collisions),
            f"{self.refused_at_start} / {self.refused_after_look}",
            str(self.short),
            f"{self.refused_true}/{self.unreachable} ({self.driven_unreachable} driven)",
            f"{np.mean(ratios):.3f} / {np.max(ratios):.3f}",
            f"{self.looks} ({self.runs_that_looked} runs)",
            f"{self.replans_said}/{self.replans_crossing}",
        ]


def side_by_side(groups: dict[str, dict[str, LoopTally]], order: list[str]) -> str:
    """A markdown table: per group, the single-shot and the closed-loop outcomes."""
    lines = [
        "| group | execution | reached (reachable) | collisions | refused at start / after a look |"
        " ended > 0.3 m away | unreachable refused, true reason | length / shortest, mean and max | looks |"
        " replans' unseen crossings said |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for group in order:
        for execution, tally in groups.get(group, {}).items():
            lines.append("| " + " | ".join([group, execution, *tally.cells()]) + " |")
    return "\n".join(lines)
