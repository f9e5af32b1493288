"""The `Reconstruction` type shared by every backbone, the services and the renderer.

Cameras follow docs/ARCHITECTURE.md: extrinsics are 3x4 camera-from-world in OpenCV axes.
"""

from __future__ import annotations

import io
import json
import math
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field

import numpy as np

from shared.geometry.motion_determinacy import FocalHypotheses

# 2: per-view intrinsics source and confidence, per-pair confidence. Version 1 files still read
# (their confidence is unknown and their intrinsics source follows from the backbone).
# 3: per-point confidence (optional). Versions 1 and 2 read with none.
# 4: `units`. Older files get the units their backbone always had (see `default_units`).
# 5: `focal_hypotheses` (optional JSON). Versions 1-4 read with none.
FORMAT_VERSION = 5
READABLE_VERSIONS = (1, 2, 3, 4, 5)
PLY_CHUNK_POINTS = 65_536

# What one unit of the world frame is: "metres" (Pi3X's metric head, posed RGB-D in metres) or
# "relative" (scale-free: classical SfM, VGGT, Pi3; only ratios of lengths mean something).
UNITS = ("metres", "relative")
_METRIC_BACKBONES = ("posed-rgbd", "pi3x")

# Where a view's intrinsics came from, best first for the classical backbone.
INTRINSICS_SOURCES = ("uploaded", "exif", "self-calibrated", "prior", "given", "predicted")
_V1_INTRINSICS_SOURCE = {"classical": "prior", "posed-rgbd": "given", "vggt": "predicted"}


def default_units(backbone: str) -> str:
    """The units of a backbone that does not say (files before format 3)."""
    return "metres" if backbone in _METRIC_BACKBONES else "relative"


class ReconstructionFormatError(ValueError):
    """Raised when serialized bytes are not a reconstruction this code can read."""


@dataclass
class ViewConfidence:
    """How well one view's pose is supported by the data. NaN / 0 where a backbone cannot tell."""

    inliers: int = 0  # observations that agree with the model (reprojection within a few pixels)
    spread: float = math.nan  # share of the image (4x4 grid cells) its inliers cover, 0..1
    reprojection_error_px: float = math.nan  # median over its inliers, original-image pixels
    positive_depth_fraction: float = math.nan  # share of its observed points in front of it
    unregistered_reason: str | None = None  # why the view has no pose; None when registered
    uncertain_reason: str | None = None  # a registered view whose pose is only partly supported


@dataclass
class PairConfidence:
    """Support of the relative pose of two registered views: the points both see."""

    first: int
    second: int
    inliers: int
    reprojection_error_px: float  # median over both views' observations of the shared points
    triangulation_angle_deg: float  # median angle between the two rays to a shared point
    # One standard deviation of the relative rotation and of the direction of travel (degrees),
    # NaN when not estimated; a pair flagged uncertain says why (the configuration) in the reason.
    rotation_uncertainty_deg: float = math.nan
    direction_uncertainty_deg: float = math.nan
    uncertain_reason: str | None = None


@dataclass
class Reconstruction:
    points: np.ndarray  # (N, 3) float32, world coordinates
    colors: np.ndarray  # (N, 3) uint8 RGB
    extrinsics: np.ndarray  # (V, 3, 4) float64 camera-from-world
    intrinsics: np.ndarray  # (V, 3, 3) float64, pixels of the original image
    image_sizes: np.ndarray  # (V, 2) int32 (width, height)
    registered: np.ndarray  # (V,) bool: False when the backbone could not place a view
    backbone: str
    backbone_version: str
    depths: list[np.ndarray] | None = None  # per view (h, w) float32 z-depth, None if not given
    depth_confidence: list[np.ndarray] | None = None  # per view (h, w) float32
    warnings: list[str] = field(default_factory=list)
    intrinsics_source: list[str] | None = None  # per view, one of INTRINSICS_SOURCES
    view_confidence: list[ViewConfidence] | None = None  # per view; None = not assessed
    pair_confidence: list[PairConfidence] = field(default_factory=list)
    # Per point, higher is surer; its scale is the backbone's (classical: how many views support the
    # point; vggt: the network's confidence). None: the backbone gives none (posed-rgbd).
    point_confidence: np.ndarray | None = None
    units: str | None = None  # one of UNITS; None: what the backbone always gives (default_units)
    # Unknown focal that the views cannot fix: each pair's poses over the supported fields of view;
    # the extrinsics above are those of the central hypothesis. None: the focal was known or fixed.
    focal_hypotheses: FocalHypotheses | None = None

    def __post_init__(self) -> None:
        if self.units is None:
            self.units = default_units(self.backbone)
        if self.units not in UNITS:
            raise ValueError(f"unknown units {self.units!r}; expected one of {UNITS}")
        self.points = np.ascontiguousarray(self.points, dtype=np.float32).reshape(-1, 3)
        self.colors = np.ascontiguousarray(self.colors, dtype=np.uint8).reshape(-1, 3)
        self.extrinsics = np.asarray(self.extrinsics, dtype=np.float64).reshape(-1, 3, 4)
        self.intrinsics = np.asarray(self.intrinsics, dtype=np.float64).reshape(-1, 3, 3)
        self.image_sizes = np.asarray(self.image_sizes, dtype=np.int32).reshape(-1, 2)
        self.registered = np.asarray(self.registered, dtype=bool).reshape(-1)
        views = len(self.extrinsics)
        if len(self.points) != len(self.colors):
            raise ValueError(f"{len(self.points)} points but {len(self.colors)} colours")
        if self.point_confidence is not None:
            self.point_confidence = np.ascontiguousarray(self.point_confidence, dtype=np.float32).reshape(-1)
            if len(self.point_confidence) != len(self.points):
                raise ValueError(f"{len(self.point_confidence)} confidences for {len(self.points)} points")
        for name in ("intrinsics", "image_sizes", "registered"):
            if len(getattr(self, name)) != views:
                raise ValueError(f"{name} has {len(getattr(self, name))} entries for {views} views")
        for name in ("depths", "depth_confidence"):
            maps = getattr(self, name)
            if maps is not None and len(maps) != views:
                raise ValueError(f"{name} has {len(maps)} maps for {views} views")
        if self.intrinsics_source is None:
            self.intrinsics_source = [_V1_INTRINSICS_SOURCE.get(self.backbone, "prior")] * views
        self.intrinsics_source = [str(source) for source in self.intrinsics_source]
        if len(self.intrinsics_source) != views:
            raise ValueError(f"intrinsics_source has {len(self.intrinsics_source)} entries for {views} views")
        unknown = sorted(set(self.intrinsics_source) - set(INTRINSICS_SOURCES))
        if unknown:
            raise ValueError(f"unknown intrinsics source(s) {unknown}; expected one of {INTRINSICS_SOURCES}")
        if self.view_confidence is None:
            self.view_confidence = [
                ViewConfidence(unregistered_reason=None if placed else "not placed by the backbone")
                for placed in self.registered
            ]
        if len(self.view_confidence) != views:
            raise ValueError(f"view_confidence has {len(self.view_confidence)} entries for {views} views")

    @property
    def num_views(self) -> int:
        return len(self.extrinsics)

    @property
    def num_points(self) -> int:
        return len(self.points)

    def camera_centers(self) -> np.ndarray:
        """(V, 3) camera centres in world coordinates."""
        rotations, translations = self.extrinsics[:, :, :3], self.extrinsics[:, :, 3]
        return -np.einsum("vji,vj->vi", rotations, translations)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds of the points and the registered camera centres (zeros if none)."""
        everything = np.concatenate([self.points.astype(np.float64), self.camera_centers()], axis=0)
        everything = everything[np.all(np.isfinite(everything), axis=1)]
        if len(everything) == 0:
            return np.zeros(3), np.zeros(3)
        return everything.min(axis=0), everything.max(axis=0)

    # ---- serialization -------------------------------------------------------------------

    def to_bytes(self) -> bytes:
        """A compact npz. Depth and confidence go as float16 (relative error < 1e-3)."""
        arrays: dict[str, np.ndarray] = {
            "format_version": np.array(FORMAT_VERSION, dtype=np.int32),
            "points": self.points,
            "colors": self.colors,
            "extrinsics": self.extrinsics,
            "intrinsics": self.intrinsics,
            "image_sizes": self.image_sizes,
            "registered": self.registered,
            "backbone": np.array(self.backbone),
            "backbone_version": np.array(self.backbone_version),
            "warnings": np.array(self.warnings, dtype=np.str_),
            "intrinsics_source": np.array(self.intrinsics_source, dtype=np.str_),
            "units": np.array(self.units),
            "confidence": np.array(
                json.dumps(
                    {
                        "views": [asdict(view) for view in self.view_confidence or []],
                        "pairs": [asdict(pair) for pair in self.pair_confidence],
                    }
                )
            ),
        }
        for name in ("depths", "depth_confidence"):
            maps = getattr(self, name)
            if maps is not None:
                for index, depth_map in enumerate(maps):
                    arrays[f"{name}_{index}"] = np.asarray(depth_map, dtype=np.float16)
        if self.point_confidence is not None:
            arrays["point_confidence"] = self.point_confidence
        if self.focal_hypotheses is not None:
            arrays["focal_hypotheses"] = np.array(json.dumps(self.focal_hypotheses.to_dict()))
        buffer = io.BytesIO()
        np.savez_compressed(buffer, **arrays)
        return buffer.getvalue()

    @classmethod
    def from_bytes(cls, payload: bytes) -> Reconstruction:
        try:
            archive = np.load(io.BytesIO(payload), allow_pickle=False)
        except Exception as error:  # numpy raises several types for garbage input
            raise ReconstructionFormatError(f"not a serialized reconstruction: {error}") from error
        with archive:
            if "format_version" not in archive:
                raise ReconstructionFormatError("missing format_version")
            version = int(archive["format_version"])
            if version not in READABLE_VERSIONS:
                raise ReconstructionFormatError(
                    f"reconstruction format {version} is not supported (this code reads "
                    f"{', '.join(map(str, READABLE_VERSIONS))})"
                )
            views = len(archive["extrinsics"])

            def maps(name: str) -> list[np.ndarray] | None:
                if f"{name}_0" not in archive:
                    return None
                return [archive[f"{name}_{i}"].astype(np.float32) for i in range(views)]

            sources, view_confidence, pair_confidence = None, None, []
            if "intrinsics_source" in archive:  # some version 1 files have it too
                sources = [str(source) for source in archive["intrinsics_source"]]
            if version >= 2:
                confidence = json.loads(str(archive["confidence"]))
                view_confidence = [ViewConfidence(**view) for view in confidence["views"]]
                pair_confidence = [PairConfidence(**pair) for pair in confidence["pairs"]]
            return cls(
                points=archive["points"],
                colors=archive["colors"],
                extrinsics=archive["extrinsics"],
                intrinsics=archive["intrinsics"],
                image_sizes=archive["image_sizes"],
                registered=archive["registered"],
                backbone=str(archive["backbone"]),
                backbone_version=str(archive["backbone_version"]),
                depths=maps("depths"),
                depth_confidence=maps("depth_confidence"),
                warnings=[str(w) for w in archive["warnings"]],
                intrinsics_source=sources,
                view_confidence=view_confidence or None,
                pair_confidence=pair_confidence,
                point_confidence=archive["point_confidence"] if "point_confidence" in archive else None,
                units=str(archive["units"]) if "units" in archive else None,
                focal_hypotheses=_focal_hypotheses(archive),
            )

    def to_ply(self) -> bytes:
        """Binary little-endian PLY of the coloured point cloud."""
        return b"".join(self.ply_chunks())

    def ply_size(self) -> int:
        return len(self._ply_header()) + 15 * self.num_points

    def ply_chunks(self, points_per_chunk: int = PLY_CHUNK_POINTS) -> Iterator[bytes]:
        """The PLY as its header, then the vertices `points_per_chunk` at a time (for streaming)."""
        yield self._ply_header()
        for start in range(0, self.num_points, points_per_chunk):
            yield self._ply_vertices(start, min(start + points_per_chunk, self.num_points))

    def _ply_header(self) -> bytes:
        return (
            "ply\nformat binary_little_endian 1.0\n"
            f"comment backbone {self.backbone} {self.backbone_version}\n"
            f"element vertex {self.num_points}\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            "end_header\n"
        ).encode("ascii")

    def _ply_vertices(self, start: int, stop: int) -> bytes:
        vertex = np.empty(
            stop - start,
            dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("r", "u1"), ("g", "u1"), ("b", "u1")],
        )
        vertex["x"], vertex["y"], vertex["z"] = self.points[start:stop].T
        vertex["r"], vertex["g"], vertex["b"] = self.colors[start:stop].T
        return vertex.tobytes()


def _focal_hypotheses(archive) -> FocalHypotheses | None:
    if "focal_hypotheses" not in archive:
        return None
    try:
        return FocalHypotheses.from_dict(json.loads(str(archive["focal_hypotheses"])))
    except (KeyError, TypeError, ValueError) as error:
        raise ReconstructionFormatError(f"unreadable focal hypotheses: {error}") from error
