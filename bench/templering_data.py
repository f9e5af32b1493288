"""The Middlebury templeRing photographs with their calibrated cameras (see the realdata README).

Found under `$PYSPATIAL_REALDATA_DIR/templeRing`, else `shared/realdata/templeRing` next to the
repository (the main checkout at /work/main, or a worktree one level deeper).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[1]
WIDTH, HEIGHT = 640, 480
SPACING_DEG = 7.7  # angle around the ring between neighbouring images (the README's figure)


def realdata_dir() -> Path | None:
    candidates = (
        [Path(os.environ["PYSPATIAL_REALDATA_DIR"])] if "PYSPATIAL_REALDATA_DIR" in os.environ else []
    )
    candidates += [REPO_ROOT / "shared" / "realdata", REPO_ROOT.parent / "shared" / "realdata"]
    candidates += [REPO_ROOT.parent.parent / "shared" / "realdata"]
    for candidate in candidates:
        if (candidate / "templeRing" / "templeR_par.txt").is_file():
            return candidate
    return None


@dataclass(frozen=True)
class TempleView:
    name: str
    intrinsic: np.ndarray  # 3x3 pixels
    extrinsic: np.ndarray  # 3x4 camera-from-world


UPSIDE_DOWN_FROM = 32  # templeR0032..0047: the stored pixels are turned 180 degrees from their calibration


def load_cameras(root: Path) -> list[TempleView]:
    """Cameras of the images as stored. The calibration of images 32-47 describes the photo the
    right way up (their relative poses to the others come out 2x the true angle otherwise), so for
    those the camera is turned 180 degrees about its axis and the principal point mirrored."""
    lines = (root / "templeRing" / "templeR_par.txt").read_text().split("\n")
    views = []
    for line in lines[1 : 1 + int(lines[0])]:
        fields = line.split()
        numbers = np.array([float(value) for value in fields[1:]])
        rotation, translation = numbers[9:18].reshape(3, 3), numbers[18:21]
        intrinsic = numbers[:9].reshape(3, 3)
        if int(fields[0][len("templeR") : -len(".png")]) >= UPSIDE_DOWN_FROM:
            flip = np.diag([-1.0, -1.0, 1.0])
            rotation, translation = flip @ rotation, flip @ translation
            intrinsic = intrinsic.copy()
            intrinsic[0, 2], intrinsic[1, 2] = WIDTH - 1 - intrinsic[0, 2], HEIGHT - 1 - intrinsic[1, 2]
        views.append(TempleView(fields[0], intrinsic, np.concatenate([rotation, translation[:, None]], 1)))
    return views


def load_image(root: Path, name: str) -> np.ndarray:
    bgr = cv2.imread(str(root / "templeRing" / name), cv2.IMREAD_COLOR)
    if bgr is None:
        raise FileNotFoundError(root / "templeRing" / name)
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def relative_pose(first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and translation of the second camera in the first camera's frame."""
    rotation = second[:, :3] @ first[:, :3].T
    return rotation, second[:, 3] - rotation @ first[:, 3]


def rotation_error_deg(a: np.ndarray, b: np.ndarray) -> float:
    cosine = np.clip((np.trace(a @ b.T) - 1.0) / 2.0, -1.0, 1.0)
    return math.degrees(math.acos(cosine))


def direction_error_deg(a: np.ndarray, b: np.ndarray) -> float:
    norms = np.linalg.norm(a) * np.linalg.norm(b)
    if norms < 1e-12:
        return 180.0
    return math.degrees(math.acos(float(np.clip(np.dot(a, b) / norms, -1.0, 1.0))))


def pair_errors(
    estimated: np.ndarray, truth: np.ndarray, registered: np.ndarray
) -> list[tuple[float, float]]:
    """(rotation error, translation-direction error) for every pair of registered views."""
    errors = []
    views = [index for index in range(len(truth)) if registered[index]]
    for position, first in enumerate(views):
        for second in views[position + 1 :]:
            true_rotation, true_translation = relative_pose(truth[first], truth[second])
            rotation, translation = relative_pose(estimated[first], estimated[second])
            errors.append(
                (
                    rotation_error_deg(rotation, true_rotation),
                    direction_error_deg(translation, true_translation),
                )
            )
    return errors
