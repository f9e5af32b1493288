"""Route plans on two-room scenes: success, length against the true shortest route, refusals.

    .venv/bin/python -m bench.route [--scenes 45] [--seed 23] [--photo-scenes 8] [--json PATH]

Scene i is kind ``reachable`` for i % 6 in 0..3, ``narrow_door`` for 4 and ``ring`` for 5
(``shared/synthetic/two_rooms.py``). Every plan is driven on the *true* geometry from the true
start pose (a disc of the robot's radius, 0.25 m, swept every 2 cm along the steps; body band
0.05-0.5 m). Success: no collision and the end within 0.3 m of the goal, on a reachable scene.
Length ratio: the plan's driven length over the true shortest route (2.5 cm grid, string pulled),
over the successes. A refusal is correct only on an unreachable scene, with a reason.

Methods on the same reconstruction:
- ``plan_route``: the planner (``shared/navigation``);
- ``straight line``: turn to face the goal, drive the straight distance;
- ``turn-then-go``: drive the goal's forward offset in the start camera's heading frame, turn
  90 degrees towards it, drive its sideways offset (how a reader of camera coordinates plans).

Inputs: ``posed RGB-D`` (exact depth and cameras: metric; the goal is the true world point) and
``photo-only (classical)`` (the RGB photos and their intrinsics only; the goal is the true
goal's pixel in view 4, located in the reconstruction; moves are scene units turned into metres by
the planner's assumed 1.5 m camera height, which is the true height here, a favourable case).
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass, field

import numpy as np

from shared.geometry.backprojection import reconstruction_from_rgbd
from shared.geometry.reconstruction import Reconstruction
from shared.navigation import locate, plan_route
from shared.navigation.floor import estimate_floor
from shared.synthetic.two_rooms import TwoRoomScene, execute_steps, generate_two_rooms, true_shortest

RADIUS = 0.25
BAND = (0.05, 0.5)
TOLERANCE_M = 0.3
_KIND_CYCLE = ("reachable",) * 4 + ("narrow_door", "ring")
METHODS = ("plan_route", "straight line", "turn-then-go")
_NO_RECONSTRUCTION = "no reconstruction"
GOAL_VIEW = 3  # the view that looks at the goal (two_rooms: the farthest corner of room B)


@dataclass
class Tally:
    reachable: int = 0
    unreachable: int = 0
    successes: int = 0
    collisions: int = 0
    short: int = 0  # ended farther than the tolerance from the goal
    false_refusals: int = 0
    correct_refusals: int = 0
    no_reconstruction: int = 0  # the backbone gave nothing to plan on (not a refusal with a reason)
    ratios: list[float] = field(default_factory=list)
    refusal_kinds: dict[str, int] = field(default_factory=dict)

    def row(self) -> dict:
        ratios = self.ratios or [float("nan")]
        return {
            "success": f"{self.successes}/{self.reachable}",
            "success_rate": self.successes / max(self.reachable, 1),
            "mean_ratio": float(np.mean(ratios)),
            "max_ratio": float(np.max(ratios)),
            "collisions": self.collisions,
            "ended_short": self.short,
            "false_refusals": self.false_refusals,
            "no_reconstruction": self.no_reconstruction,
            "unreachable_refused": f"{self.correct_refusals}/{self.unreachable}",
            "refusal_kinds": self.refusal_kinds,
        }


def _start_frame(recon: Reconstruction, goal: np.ndarray) -> tuple[float, float]:
    """The goal's (forward, left) offset on the floor in the start camera's heading frame."""
    floor = estimate_floor(recon.points, recon.extrinsics[recon.registered])
    pose = recon.extrinsics[0]
    start = floor.to_plane(-pose[:, :3].T @ pose[:, 3])[0]
    forward = floor.to_plane(pose[2, :3])[0]
    forward /= np.linalg.norm(forward)
    left = np.array([-forward[1], forward[0]])  # counter-clockwise of forward on the floor
    offset = floor.to_plane(goal)[0] - start
    return float(offset @ forward), float(offset @ left)


def baseline_steps(method: str, recon: Reconstruction, goal: np.ndarray) -> list[dict]:
    ahead, left = _start_frame(recon, goal)
    if method == "straight line":
        return [
            {"turn_degrees": float(np.degrees(np.arctan2(left, ahead))), "move": float(np.hypot(ahead, left))}
        ]
    first = {"turn_degrees": 0.0 if ahead >= 0 else 180.0, "move": abs(ahead)}
    facing_back = ahead < 0
    towards_left = left >= 0
    turn = 90.0 if towards_left != facing_back else -90.0
    return [first, {"turn_degrees": turn, "move": abs(left)}]


def _score(tally: Tally, two: TwoRoomScene, shortest: float | None, steps, refused: str | None, scale: float):
    reachable = two.kind == "reachable"
    if refused == _NO_RECONSTRUCTION:
        tally.no_reconstruction += 1
        return
    if refused is not None:
        tally.refusal_kinds[refused] = tally.refusal_kinds.get(refused, 0) + 1
        if reachable:
            tally.false_refusals += 1
        else:
            tally.correct_refusals += 1
        return
    if not reachable:
        return  # a plan for an unreachable goal: never a success
    moves = [{"turn_degrees": s["turn_degrees"], "move": s["move"] * scale} for s in steps]
    run = execute_steps(two, moves, RADIUS, BAND)
    tally.collisions += int(run.collided)
    miss = float(np.linalg.norm(run.end - two.goal[:2]))
    tally.short += int(miss > TOLERANCE_M)
    if miss <= TOLERANCE_M and not run.collided:
        tally.successes += 1
        tally.ratios.append(run.length / shortest)
        return ""
    where = (
        ""
        if run.first_collision is None
        else f" collided at ({run.first_collision[0]:.2f}, {run.first_collision[1]:.2f})"
    )
    return f"{where} ended {miss:.2f} m from the goal"


def _posed(two: TwoRoomScene, views) -> Reconstruction:
    return reconstruction_from_rgbd(
        [v.rgb for v in views], [v.depth for v in views], two.extrinsics, [two.intrinsic] * len(views)
    )


def _photo_only(
    two: TwoRoomScene, views, backbone
) -> tuple[Reconstruction | None, np.ndarray | None, str | None]:
    """The classical reconstruction and the goal located in it from its pixel, or why not."""
    from services.recon.backbones.base import BackboneError

    try:
        recon = backbone.reconstruct(
            [v.rgb for v in views],
            intrinsics=[two.intrinsic] * len(views),
            intrinsics_sources=["exif"] * len(views),
        )
    except BackboneError as error:
        return None, None, f"reconstruction failed: {error}"
    if not (recon.registered[0] and recon.registered[GOAL_VIEW]):
        return None, None, "start or goal view not placed"
    pose = two.extrinsics[GOAL_VIEW]
    pixel = two.intrinsic @ (pose[:, :3] @ two.goal + pose[:, 3])
    found = locate(recon, GOAL_VIEW, pixel[0] / pixel[2], pixel[1] / pixel[2])
    if found.point is None:
        return None, None, found.reason
    return recon, found.point, None


def _evaluate(tallies: dict, setting: str, two: TwoRoomScene, shortest, recon, goal, reason) -> str:
    """Score the planner and the baselines on one reconstruction; the planner's verdict in words."""
    for method in METHODS:
        tally = tallies.setdefault((setting, method), Tally())
        tally.reachable += int(two.kind == "reachable")
        tally.unreachable += int(two.kind != "reachable")
        if recon is None:
            _score(tally, two, shortest, [], _NO_RECONSTRUCTION, 1.0)
            continue
        if method == "plan_route":
            plan = plan_route(recon, 0, goal, robot_radius=RADIUS)
            refused = None if plan.reachable else (plan.refusal if plan.reason else "")
            note = _score(tally, two, shortest, plan.steps, refused, plan.metres_per_unit)
            verdict = f"{plan.length:.2f} m{note or ''}" if plan.reachable else f"refused ({plan.refusal})"
        else:
            scale = 1.0 if recon.units == "metres" else _assumed_metres_per_unit(recon)
            _score(tally, two, shortest, baseline_steps(method, recon, goal), None, scale)
    return verdict if recon is not None else f"no reconstruction ({reason})"


def _assumed_metres_per_unit(recon: Reconstruction) -> float:
    floor = estimate_floor(recon.points, recon.extrinsics[recon.registered])
    pose = recon.extrinsics[0]
    return 1.5 / float(floor.height(-pose[:, :3].T @ pose[:, 3])[0])


def _table(tallies: dict) -> str:
    lines = [
        "| input | method | success (reachable) | length / shortest, mean and max | collisions |"
        " ended > 0.3 m away | false refusals | no reconstruction | unreachable refused |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (setting, method), tally in tallies.items():
        row = tally.row()
        cells = [
            setting,
            method,
            f"{row['success']} ({row['success_rate']:.0%})",
            f"{row['mean_ratio']:.3f} / {row['max_ratio']:.3f}",
            row["collisions"],
            row["ended_short"],
            row["false_refusals"],
            row["no_reconstruction"],
            row["unreachable_refused"],
        ]
        lines.append("| " + " | ".join(str(cell) for cell in cells) + " |")
    return "\n".join(lines)


def main(args: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=45)
    parser.add_argument("--seed", type=int, default=23)
    parser.add_argument("--photo-scenes", type=int, default=8, help="the first N scenes also photo-only")
    parser.add_argument("--json", default=None, help="write the figures here")
    options = parser.parse_args(args)
    tallies: dict = {}
    backbone = None
    if options.photo_scenes:
        from services.recon.backbones.classical import ClassicalBackbone

        backbone = ClassicalBackbone()
    started = time.perf_counter()
    for index in range(options.scenes):
        kind = _KIND_CYCLE[index % len(_KIND_CYCLE)]
        two = generate_two_rooms(options.seed * 1000 + index, kind, radius=RADIUS, band=BAND)
        views = two.render()
        bounds = (two.scene.room_min, two.scene.room_max)
        shortest = true_shortest(two.solids, two.start_floor(), two.goal, RADIUS, BAND, bounds)
        verdict = _evaluate(tallies, "posed RGB-D", two, shortest, _posed(two, views), two.goal, None)
        line = (
            f"scene {index:2d} {kind:11s} {len(views)} views  shortest {shortest or 0:5.2f}  posed: {verdict}"
        )
        if index < options.photo_scenes:
            recon, goal, reason = _photo_only(two, views, backbone)
            line += "  photo-only: " + _evaluate(
                tallies, "photo-only (classical)", two, shortest, recon, goal, reason
            )
        print(line, flush=True)
    print(f"\n{options.scenes} scenes in {time.perf_counter() - started:.0f} s (seed {options.seed})\n")
    print(_table(tallies))
    if options.json:
        rows = [{"input": s, "method": m, **t.row()} for (s, m), t in tallies.items()]
        with open(options.json, "w") as handle:
            json.dump({"seed": options.seed, "scenes": options.scenes, "rows": rows}, handle, indent=2)


if __name__ == "__main__":
    main()
