"""A path's corners to steps ``{turn_degrees, move, unseen_m}`` and sentences that say what was assumed.

Each move is sampled every half cell; a sample whose cell is unseen floor (no view saw the floor,
nothing seen at body height) counts towards the step's ``unseen_m``, and each run of such samples
is an unseen stretch (world end points and the 1-based step). A stretch shorter than one cell is
sampling noise at the seen floor's edge and is not reported.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

_MIN_TURN_DEG = 0.5
UNSEEN_ADVICE = "go slowly and look again"


@dataclass(frozen=True)
class Stretch:
    step: int  # 1-based step whose move crosses it
    start: float  # distance along that move where it begins (output units)
    end: float
    start_plane: np.ndarray  # (2,) floor coordinates
    end_plane: np.ndarray


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) indices of the runs of True."""
    padded = np.concatenate([[False], flags, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def unseen_stretches(
    a: np.ndarray, b: np.ndarray, is_unseen: Callable[[np.ndarray], np.ndarray], spacing: float
) -> list[tuple[float, float]]:
    """(from, to) distances along a -> b (scene units) over unseen floor, each at least ``2 * spacing``."""
    length = float(np.linalg.norm(b - a))
    count = max(int(np.ceil(length / spacing)), 1)
    along = np.linspace(0.0, length, count + 1)
    flags = is_unseen(a + (along / max(length, 1e-12))[:, None] * (b - a))
    out = []
    for first, last in _runs(flags):
        low = max(along[first] - 0.5 * spacing, 0.0)
        high = min(along[last] + 0.5 * spacing, length)
        if high - low >= 2 * spacing - 1e-9:
            out.append((low, high))
    return out


def turn_words(turn: float) -> str:
    return f"turn {'left' if turn > 0 else 'right'} {abs(turn):.0f}°"


def _unseen_words(move: float, runs: list[tuple[float, float]], unit: str) -> str:
    """The clause that says which part of a move crosses unseen floor ('' when none does)."""
    if not runs:
        return ""
    total = sum(high - low for low, high in runs)
    tolerance = 0.005 + 0.02 * move
    if total >= move - tolerance:
        where = "all of it crosses"
    elif len(runs) == 1 and runs[0][1] >= move - tolerance:
        where = f"the last {total:.2f} {unit} crosses"
    elif len(runs) == 1 and runs[0][0] <= tolerance:
        where = f"the first {total:.2f} {unit} crosses"
    else:
        spans = ", ".join(f"{low:.2f}-{high:.2f}" for low, high in runs)
        where = f"{total:.2f} {unit} of it ({spans} {unit} along) crosses"
    return f" ({where} floor no photo shows: {UNSEEN_ADVICE})"


def steps_and_sentences(
    corners: np.ndarray,
    heading: float,
    units: str,
    per_output: float,
    is_unseen: Callable[[np.ndarray], np.ndarray],
    spacing: float,
) -> tuple[list[dict], list[str], list[Stretch]]:
    """Steps (moves: scene units over ``per_output``), their sentences and the unseen stretches."""
    steps, sentences, stretches = [], [], []
    unit = "m" if units == "metres" else "scene units"
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        offset = b - a
        length = float(np.linalg.norm(offset))
        if length <= 1e-9:
            continue
        move = length / per_output
        direction = float(np.arctan2(offset[1], offset[0]))
        turn = float(np.degrees((direction - heading + np.pi) % (2 * np.pi) - np.pi))
        heading = direction
        runs = [
            (low / per_output, high / per_output) for low, high in unseen_stretches(a, b, is_unseen, spacing)
        ]
        unseen = sum(high - low for low, high in runs)
        steps.append({"turn_degrees": round(turn, 2), "move": round(move, 4), "unseen_m": round(unseen, 4)})
        for low, high in runs:
            points = a + np.array([[low], [high]]) * per_output / length * offset
            stretches.append(Stretch(len(steps), low, high, points[0], points[1]))
        go = f"go forward {move:.2f} {unit}{_unseen_words(move, runs, unit)}"
        sentences.append(f"{turn_words(turn)}, then {go}" if abs(turn) >= _MIN_TURN_DEG else go)
    return steps, [sentence[0].upper() + sentence[1:] for sentence in sentences], stretches
