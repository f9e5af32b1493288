"""Where to look next when no photo shows a way: a pose on driveable floor facing the likeliest gap.

A refusal ``unseen_space`` means that every way to the goal passes through space no view looked
into, across the line of a seen wall running into it: a doorway there, if any, no photo shows.
Which stretch of that wall is a doorway the photos do not tell, so no route is claimed. What the
robot can do is look: ``next_look`` searches the map with the unlooked space open (seen walls
*not* continued into it, the seen obstacles and the unseen bodies behind their faces closed), at a
cost per metre of unlooked space high enough that the search crosses as little of it as it can.
The first unlooked cell on that search's path is where the way most likely opens; the robot
stands on floor the first search may drive (nothing assumed on the way there), ``LOOK_FROM_M``
back along that path, with a line of sight to it, and faces it. After a new photo from there the
plan is made again: a doorway seen there gives a route, a wall seen there moves the next look.

This is frontier exploration (the boundary between looked-into and unlooked space, chosen by the
way to the goal), the step Nav2-style stacks leave to an explorer node; it is written here because
it needs the planner's own map kinds (looked-into, shadows, continued walls) to choose the frontier.

Distances are in the plan's units: ``per_metre`` scene units per metre, ``per_output`` scene units
per unit of the moves. Floor coordinates are ``Floor.to_plane``'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.navigation.floor import Floor
from shared.navigation.grid import Grid, dilate
from shared.navigation.search import astar, segment_is_clear, shorten
from shared.navigation.steps import steps_and_sentences, turn_words

# A photo of a gap taken from about this far frames a few metres of wall and the floor at its foot
# (a camera pitched down frames nothing of the floor within a metre or so of itself).
LOOK_FROM_M = 2.0
# A metre through unlooked space costs this many over seen floor: the search crosses the thinnest
# band of it, so the frontier it finds lies on the way rather than behind the start.
_UNLOOKED_COST = 20.0


@dataclass(frozen=True)
class Look:
    """A pose to take the next photo from, and the moves that get the robot there."""

    stand_plane: np.ndarray  # (2,) floor coordinates
    face_plane: np.ndarray  # (2,) the first unlooked point on the likeliest way
    steps: list[dict]  # {turn_degrees, move, unseen_m}: the last one turns to face, moving 0
    sentences: list[str]

    def to_dict(self, floor: Floor) -> dict:
        return {
            "stand_world": np.round(floor.to_world(self.stand_plane)[0], 4).tolist(),
            "face_world": np.round(floor.to_world(self.face_plane)[0], 4).tolist(),
            "steps": self.steps,
            "sentences": self.sentences,
        }


def next_look(
    grid: Grid,
    behind_faces: np.ndarray | None,
    driveable: np.ndarray,
    cost: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    start_plane: np.ndarray,
    heading: float,
    radius_cells: float,
    per_metre: float,
    per_output: float,
    units: str,
) -> Look | None:
    """The next photo's pose for a goal every way to which crosses unlooked space, or None when the
    seen obstacles (and their unseen bodies) close every way even with all of it open.

    ``driveable``: the first search's passable cells (nothing unlooked within the robot's reach);
    ``cost``: its per-cell cost; ``behind_faces``: ``shadow.shadows`` (None: none computed);
    ``heading``: the robot's heading at ``start`` (radians, counter-clockwise on the floor plane).
    """
    open_ = ~dilate(seen_closed(grid, behind_faces), radius_cells)
    cells = astar(open_, start, goal, np.where(grid.hidden, _UNLOOKED_COST, cost))
    if cells is None:
        return None
    path = np.array(cells)
    unlooked = grid.hidden[path[:, 0], path[:, 1]]
    if not unlooked.any():
        return None
    first = int(np.argmax(unlooked))
    target = path[first]
    # the robot drives only what the first search may: up to where the path leaves that floor
    safe = driveable[path[:first, 0], path[:first, 1]]
    reach = int(np.argmin(safe)) if not safe.all() else first
    stand = _stand_index(grid, path, reach, target, LOOK_FROM_M * per_metre / grid.cell)
    corners = grid.to_plane(np.array(shorten(driveable, cells[: stand + 1], cost)))
    corners[0] = start_plane
    steps, sentences, _ = steps_and_sentences(
        corners, heading, units, per_output, lambda plane: grid.unseen[_cells(grid, plane)], 0.5 * grid.cell
    )
    face = grid.to_plane(target[None])[0]
    for step in steps:
        heading += np.radians(step["turn_degrees"])
    towards = float(np.arctan2(*(face - corners[-1])[::-1]))
    turn = round(float(np.degrees((towards - heading + np.pi) % (2 * np.pi) - np.pi)), 2)
    steps.append({"turn_degrees": turn, "move": 0.0, "unseen_m": 0.0})
    facing = (
        "to face the space no view looked into"
        if abs(turn) >= 0.5
        else "facing the space no view looked into"
    )
    sentences.append(
        f"{turn_words(turn).capitalize()} {facing}, and take a photo"
        if abs(turn) >= 0.5
        else f"Take a photo {facing}"
    )
    return Look(stand_plane=corners[-1], face_plane=face, steps=steps, sentences=sentences)


def seen_closed(grid: Grid, behind_faces: np.ndarray | None) -> np.ndarray:
    """(H, W) bool: what closes the way with all unlooked space open: the seen obstacles, the unseen
    bodies behind their faces, the map's edge (no seen wall continued into unlooked space)."""
    closed = grid.occupied.copy()
    if behind_faces is not None:
        closed |= behind_faces
    closed[[0, -1], :] = True
    closed[:, [0, -1]] = True
    return closed


def _stand_index(grid: Grid, path: np.ndarray, reach: int, target: np.ndarray, back_cells: float) -> int:
    """The path cell to look from: the last driveable one at least ``back_cells`` from the target
    with a line of sight to it; else the farthest-back one in sight; else the start."""
    sight = ~grid.occupied
    in_sight = [i for i in range(reach) if _sees(sight, path[i], target)]
    far_enough = [i for i in in_sight if np.linalg.norm(path[i] - target) >= back_cells]
    if far_enough:
        return far_enough[-1]
    return in_sight[0] if in_sight else 0


def _sees(clear: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Nothing seen standing between cell a and cell b (the target's own cell not counted)."""
    direction = b - a
    length = float(np.linalg.norm(direction))
    if length < 1.0:
        return True
    short = b - direction / length  # stop a cell before the target: its neighbours may be the gap's jambs
    return segment_is_clear(clear, a, short)


def _cells(grid: Grid, plane: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cells = grid.to_cell(plane)
    cells[:, 0] = np.clip(cells[:, 0], 0, grid.shape[0] - 1)
    cells[:, 1] = np.clip(cells[:, 1], 0, grid.shape[1] - 1)
    return cells[:, 0], cells[:, 1]
