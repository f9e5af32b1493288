"""Procedural solid textures: a colour for any 3D point of a material, with no image lookups.

Each material tiles space with two lattices of cubic cells (coarse and fine), tilted by its own
rotation so the cells cut the room's planes at odd angles. Every cell gets a pseudo-random colour
from a hash of its integer coordinates, so the pattern is dense in corners (good for ORB/SIFT),
never repeats, and is the same from every viewpoint (good for matching across views).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Material:
    name: str
    base_rgb: tuple[float, float, float]  # albedo in [0, 1]
    salt: int  # decorrelates the texture of surfaces that share a base colour
    lattice_rotation: np.ndarray  # (3, 3): tilts the texture cells off the room's axes
    coarse_cell: float  # metres
    fine_cell: float  # metres


def _mix64(values: np.ndarray) -> np.ndarray:
    """A 64-bit avalanche finalizer: nearby inputs give unrelated outputs."""
    z = values.astype(np.uint64)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def _cell_values(cells: np.ndarray, salt: np.ndarray, channels: int) -> np.ndarray:
    """Uniform [0, 1) values per integer cell (N, 3) and salt (N,): shape (N, channels)."""
    as_unsigned = cells.astype(np.int64).view(np.uint64)
    key = salt.astype(np.uint64)
    for axis, prime in enumerate((0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9)):
        key = _mix64(key ^ (as_unsigned[:, axis] * np.uint64(prime)))
    out = np.empty((len(cells), channels), np.float64)
    for channel in range(channels):
        key = _mix64(key + np.uint64(0x9E3779B97F4A7C15))
        out[:, channel] = (key >> np.uint64(11)).astype(np.float64) / float(1 << 53)
    return out


def material_table(materials: list[Material]) -> dict[str, np.ndarray]:
    """Per-material parameters stacked into arrays so shading can gather them per pixel."""
    return {
        "base": np.array([m.base_rgb for m in materials], np.float64),
        "salt": np.array([m.salt for m in materials], np.uint64),
        "rotation": np.stack([m.lattice_rotation for m in materials]),
        "coarse": np.array([m.coarse_cell for m in materials], np.float64),
        "fine": np.array([m.fine_cell for m in materials], np.float64),
    }


def albedo(points: np.ndarray, material_ids: np.ndarray, table: dict[str, np.ndarray]) -> np.ndarray:
    """Texture colour in [0, 1] (N, 3) at world points (N, 3) of the given materials (N,)."""
    local = np.einsum("nij,nj->ni", table["rotation"][material_ids], points)
    salt = table["salt"][material_ids]
    coarse = _cell_values(np.floor(local / table["coarse"][material_ids, None]), salt, 3)
    fine = _cell_values(np.floor(local / table["fine"][material_ids, None]), salt + np.uint64(1), 1)
    base = table["base"][material_ids]
    # Brightness varies strongly (corners for detectors); hue varies a little (distinct cells).
    brightness = 0.3 + 0.6 * coarse.mean(axis=1, keepdims=True) + 0.4 * (fine - 0.5)
    tint = 0.1 * (coarse - 0.5)
    return np.clip(base * brightness + tint + 0.08, 0.0, 1.0)
