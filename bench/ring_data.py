"""Any ring of calibrated photographs in the Middlebury multi-view format, for the benches.

A folder holds the images and one `<name>_par.txt`: a count line, then per image its file name,
K (3x3, row-major), R (3x3, row-major) and t, camera-from-world. `<name>_ang.txt` (latitude,
longitude, name per line), when present, gives each image's azimuth around the ring; without it
the azimuth is that of the camera centre around the centres' mean, in their best-fit plane.

templeRing is read through bench.templering_data (its images 32-47 are stored turned 180 degrees
from their calibration, which that module corrects); every other ring is read as written.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from bench.templering_data import TempleView, load_cameras


@dataclass(frozen=True)
class Ring:
    folder: Path  # the images and the _par.txt
    views: list[TempleView]  # in the _par.txt's order; a subset names them 1-based
    azimuths: dict[int, float]  # 1-based image number -> azimuth (degrees)

    @property
    def name(self) -> str:
        return self.folder.name

    @property
    def step_deg(self) -> float:
        """The mean angle between neighbouring images around the ring."""
        return 360.0 / len(self.views)

    def image(self, number: int) -> np.ndarray:
        path = self.folder / self.views[number - 1].name
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            raise FileNotFoundError(path)
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def parameter_file(folder: Path) -> Path:
    found = sorted(folder.glob("*_par.txt"))
    if len(found) != 1:
        raise SystemExit(f"{folder}: expected one *_par.txt, found {len(found)}")
    return found[0]


def read_par(path: Path) -> list[TempleView]:
    lines = path.read_text().split("\n")
    views = []
    for line in lines[1 : 1 + int(lines[0])]:
        fields = line.split()
        numbers = np.array([float(value) for value in fields[1:22]])
        extrinsic = np.concatenate([numbers[9:18].reshape(3, 3), numbers[18:21, None]], axis=1)
        views.append(TempleView(fields[0], numbers[:9].reshape(3, 3), extrinsic))
    return views


def load_ring(folder: Path) -> Ring:
    par = parameter_file(folder)
    views = load_cameras(folder.parent) if par.name == "templeR_par.txt" else read_par(par)
    return Ring(folder, views, azimuths(par, views))


def azimuths(par: Path, views: list[TempleView]) -> dict[int, float]:
    numbers = {view.name: index + 1 for index, view in enumerate(views)}
    angles = par.with_name(par.name.replace("_par.txt", "_ang.txt"))
    if angles.is_file():
        found = {}
        for line in angles.read_text().split("\n"):
            fields = line.split()
            if len(fields) == 3 and fields[2] in numbers:
                found[numbers[fields[2]]] = float(fields[1])
        return found
    centres = np.array([-view.extrinsic[:, :3].T @ view.extrinsic[:, 3] for view in views])
    offsets = centres - centres.mean(axis=0)
    across, along = np.linalg.svd(offsets)[2][:2]  # the ring's plane
    angles_deg = np.degrees(np.arctan2(offsets @ along, offsets @ across))
    return {index + 1: float(angle) for index, angle in enumerate(angles_deg)}


def ring_subset(
    ring: Ring, start: int, count: int, step: int, tolerance_deg: float = 2.0
) -> list[int] | None:
    """`count` images `step` ring steps apart from `start` (the image nearest each target azimuth,
    within the tolerance; None when the ring has a gap there)."""
    chosen = [start]
    for index in range(1, count):
        target = ring.azimuths[start] + index * step * ring.step_deg
        best = min(ring.azimuths, key=lambda image: abs((ring.azimuths[image] - target + 180) % 360 - 180))
        if abs((ring.azimuths[best] - target + 180) % 360 - 180) > tolerance_deg or best in chosen:
            return None
        chosen.append(best)
    return chosen
