"""Real photographs with calibrated cameras (the Middlebury templeRing set) for tests.

The data lives outside the repository, in `shared/realdata/` next to the checkout (or a folder
above it, for git worktrees); `PYSPATIAL_REALDATA_DIR` overrides the search.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from shared.local.services import REPO_ROOT


def realdata_dir() -> Path:
    override = os.environ.get("PYSPATIAL_REALDATA_DIR")
    candidates = [Path(override)] if override else []
    candidates += [folder / "shared" / "realdata" for folder in REPO_ROOT.parents[:3]]
    for candidate in candidates:
        if (candidate / "templeRing" / "templeR_par.txt").is_file():
            return candidate
    searched = ", ".join(str(c) for c in candidates)
    raise FileNotFoundError(f"the real-data folder (templeRing) is missing; looked in {searched}")


@dataclass(frozen=True)
class CalibratedView:
    path: Path
    intrinsic: np.ndarray  # 3x3, pixels
    extrinsic: np.ndarray  # 3x4 camera-from-world, OpenCV axes


@lru_cache(maxsize=1)
def temple_ring() -> dict[int, CalibratedView]:
    """Image number (1..47) -> its file and calibrated camera, from templeR_par.txt."""
    folder = realdata_dir() / "templeRing"
    views = {}
    for line in (folder / "templeR_par.txt").read_text().splitlines()[1:]:
        fields = line.split()
        if len(fields) != 22:
            continue
        values = np.array(fields[1:], dtype=np.float64)
        rotation, translation = values[9:18].reshape(3, 3), values[18:21]
        number = int(fields[0].removeprefix("templeR").removesuffix(".png"))
        views[number] = CalibratedView(
            folder / fields[0], values[:9].reshape(3, 3), np.hstack([rotation, translation[:, None]])
        )
    return views


def rotation_error_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(a @ b.T) - 1) / 2, -1, 1))))


def pose_errors(truth: list[np.ndarray], estimate: list[np.ndarray]) -> list[tuple[float, float]]:
    """Per view after the first: (rotation error, direction error of the centre seen from view 0), degrees.

    Both are relative to the first view, so the estimate's frame and scale do not matter.
    """
    errors = []
    for true_pose, pose in zip(truth[1:], estimate[1:], strict=True):
        rotation = pose[:, :3] @ estimate[0][:, :3].T
        true_rotation = true_pose[:, :3] @ truth[0][:, :3].T
        centre = estimate[0][:, :3] @ (-pose[:, :3].T @ pose[:, 3]) + estimate[0][:, 3]
        true_centre = truth[0][:, :3] @ (-true_pose[:, :3].T @ true_pose[:, 3]) + truth[0][:, 3]
        cosine = centre @ true_centre / (np.linalg.norm(centre) * np.linalg.norm(true_centre))
        direction = float(np.degrees(np.arccos(np.clip(cosine, -1, 1))))
        errors.append((rotation_error_deg(rotation, true_rotation), direction))
    return errors
