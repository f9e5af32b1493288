"""Z-buffered point splatting on the CPU (numpy), and novel views of a `Reconstruction`.

The z-test packs each candidate pixel write into one int64 key: the float32 depth's bit pattern in
the high 32 bits (for positive floats the bit pattern orders like the value) and the point index in
the low 32 bits. `np.minimum.at` over those keys leaves, per pixel, the nearest point; equal depths
go to the lower index, so the result does not depend on write order.

Splats are squares of `side` pixels. A radius r gives side = max(1, round(2 r)); the square covers
offsets -(side-1)//2 .. side//2 around the point's pixel (pixel index = floor(u + 0.5), the integer
pixel convention of docs/ARCHITECTURE.md).

Crack filling (optional, on by default in `synthesize_novel_view`) closes pinholes where the splats of
neighbouring points do not quite meet. An empty pixel is filled when at least CRACK_MIN_NEIGHBOURS of
its 8 neighbours are drawn, two of them on opposite sides of it (left and right, above and below, or
diagonally; 5 drawn always include such a pair), and the drawn neighbours' points lie within
CRACK_DEPTH_TOLERANCE of each other in depth (one surface: no silhouette, no depth step). It takes
the key of its nearest neighbour (smallest key: the z-test's winner). CRACK_PASSES passes, each
computed from the previous one's buffer. A filled pixel lies between two drawn ones, so a straight or
convex outline never grows and a concave corner gains at most one pixel per pass; a large empty
region keeps everything but its corners. Only empty pixels are filled: a crack through which a
farther surface was drawn keeps that surface.
"""

from __future__ import annotations

import numpy as np

from shared.geometry.poses import validate_extrinsic
from shared.geometry.reconstruction import Reconstruction

NEAR_PLANE = 1e-4  # points closer than this to the camera plane are dropped
MAX_SPLAT_SIDE = 15  # caps the cost of points right in front of the camera
# Splat side for a sample spacing that projects to p pixels: ceil(SPLAT_MARGIN * p - SPLAT_SLACK).
# The margin covers a surface seen more obliquely than in its input view (its spacing stretches more
# along one image axis); the slack keeps p = 1, an input view seen from its own pose, at one pixel,
# while anything more than 1% above one pixel gets two.
SPLAT_MARGIN = 1.25
SPLAT_SLACK = SPLAT_MARGIN - 1.0 + 0.01
# 2**16 units in the last place of a float32 depth is about 0.8% of the depth.
OFFSET_DEPTH_PENALTY_ULPS = 2**16
# Crack filling: drawn neighbours (of 8) an empty pixel needs, the largest relative depth spread
# (farthest / nearest - 1) of their points, and the number of passes. Two passes close one-pixel
# cracks, their crossings (second pass) and holes up to 2x2; a 3x3 hole keeps its centre and cracks
# two pixels wide stay (automatic splat sizes keep those from appearing).
CRACK_MIN_NEIGHBOURS = 4
CRACK_DEPTH_TOLERANCE = 0.05
CRACK_PASSES = 2
_EMPTY = np.iinfo(np.int64).max
_INDEX_MASK = np.int64(0xFFFFFFFF)


def _check_intrinsic(intrinsic: np.ndarray) -> np.ndarray:
    matrix = np.asarray(intrinsic, dtype=np.float64)
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise ValueError(f"intrinsic must be a finite 3x3 matrix, got shape {matrix.shape}")
    if matrix[0, 0] <= 0 or matrix[1, 1] <= 0:
        raise ValueError(f"focal lengths must be positive, got fx={matrix[0, 0]}, fy={matrix[1, 1]}")
    return matrix


def _per_point(value: float | np.ndarray, count: int, name: str) -> np.ndarray:
    array = np.asarray(value, dtype=np.float32)
    if array.ndim == 0:
        array = np.full(count, array, dtype=np.float32)
    if array.shape != (count,):
        raise ValueError(f"{name} must be a number or one value per point, got shape {array.shape}")
    return array


def _splat_sides(
    count: int,
    inverse_depth: np.ndarray,
    focal: float,
    point_radius_px: float | np.ndarray | None,
    point_spacing: float | np.ndarray | None,
    kept: np.ndarray,
) -> int | np.ndarray:
    """Splat side in pixels: one number for all points, or one per kept point."""
    if point_radius_px is not None:
        radius = np.asarray(point_radius_px, dtype=np.float32)
        if radius.ndim == 0:
            return int(np.clip(np.rint(2.0 * float(radius)), 1, MAX_SPLAT_SIDE))
        sides = np.rint(2.0 * _per_point(radius, count, "point_radius_px")[kept])
    elif point_spacing is not None:
        spacing = _per_point(point_spacing, count, "point_spacing")[kept]
        with np.errstate(invalid="ignore", over="ignore"):
            projected = spacing * (np.float32(focal * SPLAT_MARGIN) * inverse_depth[kept])
            sides = np.ceil(np.nan_to_num(projected - np.float32(SPLAT_SLACK), nan=1.0))
    else:
        return 1
    return np.clip(sides, 1, MAX_SPLAT_SIDE).astype(np.int64)


def _square_offsets(side: int, row_stride: int) -> tuple[np.ndarray, np.ndarray]:
    """Flat buffer offsets of a side x side square around a pixel, and their key penalties.

    The penalty adds OFFSET_DEPTH_PENALTY_ULPS per pixel of distance from the splat centre to the
    depth bits, so that where two samplings of one surface overlap, each pixel keeps the point that
    projects onto it instead of a neighbour's splat that is nearer by a rounding error.
    """
    steps = np.arange(-((side - 1) // 2), side // 2 + 1, dtype=np.int64)
    offsets = (steps[:, None] * row_stride + steps[None, :]).ravel()
    distance = np.maximum(np.abs(steps)[:, None], np.abs(steps)[None, :]).ravel()
    return offsets, (distance * OFFSET_DEPTH_PENALTY_ULPS) << 32


def _fill_cracks(buffer: np.ndarray, depth: np.ndarray, height: int, width: int, pad: int) -> None:
    """Fill small holes of the padded (rows, row_stride) key buffer in place (see the module doc).

    The one-pixel ring around the image lies inside the padding and holds the points projecting
    just outside it, so border pixels see true neighbours. Candidates come from a uint8 count of
    drawn neighbours over shifted slices; only they gather their 8 neighbour keys.
    """
    row_stride = buffer.shape[1]
    flat = buffer.reshape(-1)
    rows, columns = np.mgrid[-1:2, -1:2]
    ring = (rows * row_stride + columns).ravel()
    ring = ring[ring != 0]
    window = (slice(pad - 1, pad + height + 1), slice(pad - 1, pad + width + 1))
    for _ in range(CRACK_PASSES):
        drawn = (buffer[window] != _EMPTY).view(np.uint8)
        count = np.zeros((height, width), dtype=np.uint8)
        for row in range(3):
            for column in range(3):
                if row != 1 or column != 1:
                    count += drawn[row : row + height, column : column + width]
        candidate = (count >= CRACK_MIN_NEIGHBOURS) & (drawn[1:-1, 1:-1] == 0)
        local = np.flatnonzero(candidate)
        if len(local) == 0:
            return
        at = (local // width + pad) * row_stride + (local % width + pad)
        # (8, candidates): reductions over the 8 neighbours run as element-wise operations on rows.
        keys = flat[ring[:, None] + at[None, :]]
        hit = keys != _EMPTY
        # Ring order is row-major without the centre, so neighbour k faces neighbour 7 - k.
        sandwiched = np.any(hit & hit[::-1], axis=0)
        nearest = keys.min(axis=0)
        farthest = np.where(hit, keys, 0).max(axis=0)
        # The z-test's choice of nearest and farthest neighbour; their points' true depths for the
        # spread (key depth bits carry the splat-offset penalty).
        near_depth, far_depth = depth[nearest & _INDEX_MASK], depth[farthest & _INDEX_MASK]
        fill = sandwiched & (far_depth <= near_depth * np.float32(1.0 + CRACK_DEPTH_TOLERANCE))
        flat[at[fill]] = nearest[fill]


def _packed_z_buffer(
    points: np.ndarray,
    extrinsic: np.ndarray,
    intrinsic: np.ndarray,
    width: int,
    height: int,
    point_radius_px: float | np.ndarray | None,
    point_spacing: float | np.ndarray | None,
    fill_cracks: bool = False,
) -> np.ndarray:
    """(height, width) int64 view: per pixel the packed (depth bits, point index) key of the winner."""
    cloud = np.asarray(points)
    if cloud.ndim != 2 or cloud.shape[1] != 3:
        raise ValueError(f"points must be (N, 3), got shape {cloud.shape}")
    if width <= 0 or height <= 0:
        raise ValueError(f"image size must be positive, got {width}x{height}")
    if len(cloud) >= 2**32:
        raise ValueError("at most 2**32 - 1 points can be rendered at once")
    pose = validate_extrinsic(extrinsic)
    camera = _check_intrinsic(intrinsic)

    rotation = pose[:3, :3].astype(np.float32)
    in_camera = cloud.astype(np.float32, copy=False) @ rotation.T + pose[:3, 3].astype(np.float32)
    depth = in_camera[:, 2]
    # A splat reaches at most MAX_SPLAT_SIDE // 2 pixels from its centre: points that far outside
    # can still touch the image, and a border of MAX_SPLAT_SIDE keeps every write in the buffer.
    reach, pad = MAX_SPLAT_SIDE // 2, MAX_SPLAT_SIDE
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse_depth = np.float32(1.0) / depth
        # + 0.5 then floor: the nearest integer pixel, as pixel centres sit on integers.
        u = in_camera[:, 0] * inverse_depth * np.float32(camera[0, 0]) + np.float32(camera[0, 2] + 0.5 + pad)
        v = in_camera[:, 1] * inverse_depth * np.float32(camera[1, 1]) + np.float32(camera[1, 2] + 0.5 + pad)
        visible = depth > NEAR_PLANE
        visible &= (
            (u > pad - reach) & (u < pad + width + reach) & (v > pad - reach) & (v < pad + height + reach)
        )
    kept = np.flatnonzero(visible)
    row_stride = width + 2 * pad
    pixel = np.floor(v[kept]).astype(np.int64) * row_stride + np.floor(u[kept]).astype(np.int64)
    # Positive float32 depths order like their bit patterns, so one integer minimum does the z-test.
    keys = (depth[kept].view(np.int32).astype(np.int64) << 32) | kept
    focal = float(np.sqrt(camera[0, 0] * camera[1, 1]))
    sides = _splat_sides(len(cloud), inverse_depth, focal, point_radius_px, point_spacing, kept)

    buffer = np.full((height + 2 * pad) * row_stride, _EMPTY, dtype=np.int64)
    groups = [(sides, slice(None))] if isinstance(sides, int) else [(s, sides == s) for s in np.unique(sides)]
    for side, members in groups:
        if side == 1:
            np.minimum.at(buffer, pixel[members], keys[members])
            continue
        offsets, penalties = _square_offsets(int(side), row_stride)
        targets = (pixel[members][:, None] + offsets[None, :]).ravel()
        np.minimum.at(buffer, targets, (keys[members][:, None] + penalties[None, :]).ravel())
    buffer = buffer.reshape(height + 2 * pad, row_stride)
    if fill_cracks:
        _fill_cracks(buffer, depth, height, width, pad)
    return buffer[pad : pad + height, pad : pad + width]


def rasterize_points(
    points: np.ndarray,
    extrinsic: np.ndarray,
    intrinsic: np.ndarray,
    width: int,
    height: int,
    point_radius_px: float | np.ndarray | None = None,
    point_spacing: float | np.ndarray | None = None,
    fill_cracks: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel, the index of the nearest splat's point (-1 if none) and its z-depth (inf if none).

    Splat size, first that applies: `point_radius_px` (number or one per point); `point_spacing`
    (world distance between neighbouring samples, number or per point): the side is the spacing
    projected at the point's depth p = f * spacing / z, side = ceil(SPLAT_MARGIN * p - SPLAT_SLACK);
    else one pixel. With `fill_cracks`, small holes inside a surface take the index and depth of
    their nearest drawn neighbour (see the module doc).
    """
    packed = _packed_z_buffer(
        points, extrinsic, intrinsic, width, height, point_radius_px, point_spacing, fill_cracks
    )
    hit = packed != _EMPTY
    index = np.where(hit, packed & _INDEX_MASK, -1)
    z_buffer = np.full((height, width), np.inf, dtype=np.float32)
    z_buffer[hit] = (packed[hit] >> 32).astype(np.int32).view(np.float32)
    return index, z_buffer


def render_point_cloud(
    points: np.ndarray,
    colors: np.ndarray,
    extrinsic: np.ndarray,
    intrinsic: np.ndarray,
    width: int,
    height: int,
    point_radius_px: float | np.ndarray | None = None,
    background: tuple[int, int, int] = (255, 255, 255),
    point_spacing: float | np.ndarray | None = None,
    fill_cracks: bool = False,
) -> np.ndarray:
    """(height, width, 3) uint8 image of coloured points; the nearest point wins each pixel.

    Splat sizes and `fill_cracks` as in `rasterize_points`; without radius or spacing every point
    is one pixel.
    """
    count = len(np.asarray(points))
    palette = np.asarray(colors)
    if palette.shape != (count, 3):
        raise ValueError(f"colors must be (N, 3) for {count} points, got {palette.shape}")
    packed = _packed_z_buffer(
        points, extrinsic, intrinsic, width, height, point_radius_px, point_spacing, fill_cracks
    )
    # Empty pixels index one extra palette row holding the background: a single gather.
    index = np.where(packed != _EMPTY, packed & _INDEX_MASK, count)
    with_background = np.concatenate([palette.astype(np.uint8, copy=False), [background]]).astype(np.uint8)
    return with_background[index]


def sample_spacing(recon: Reconstruction) -> np.ndarray:
    """Estimated world distance between neighbouring points, one value per point.

    Points come from per-pixel depth of the input views, so a point at z-depth z in the view that
    sampled it is about z / f from its neighbours (f: focal in pixels of the grid it was sampled on:
    the depth map when the reconstruction has depths, else the image). Which view sampled a point
    is not recorded, so the largest z / f over the registered views whose image contains the point
    is used: splats then err on the large side, where the nearest point still wins, instead of
    leaving holes. A point no view contains gets its distance to the nearest camera centre over
    the mean focal. With fewer points than valid grid pixels (strided or filtered sampling) the
    spacing grows by sqrt(grid pixels / points).
    """
    views = np.flatnonzero(recon.registered)
    if len(views) == 0 or recon.num_points == 0:
        return np.ones(recon.num_points, dtype=np.float32)
    points = recon.points
    spacing = np.zeros(len(points), dtype=np.float32)
    focals, grid_pixels = [], 0
    for view in views:
        width, height = (int(size) for size in recon.image_sizes[view])
        grid_scale = 1.0
        if recon.depths is not None:
            depth_map = recon.depths[view]
            grid_scale = depth_map.shape[1] / width
            grid_pixels += int(np.count_nonzero(np.isfinite(depth_map) & (depth_map > 0)))
        else:
            grid_pixels += width * height
        intrinsic = recon.intrinsics[view]
        focal = grid_scale * float(np.sqrt(intrinsic[0, 0] * intrinsic[1, 1]))
        focals.append(focal)
        pose = recon.extrinsics[view].astype(np.float32)
        in_camera = points @ pose[:, :3].T + pose[:, 3]
        depth = in_camera[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = in_camera[:, 0] / depth * np.float32(intrinsic[0, 0]) + np.float32(intrinsic[0, 2])
            v = in_camera[:, 1] / depth * np.float32(intrinsic[1, 1]) + np.float32(intrinsic[1, 2])
            inside = (depth > 0) & (u > -1) & (u < width) & (v > -1) & (v < height)
        np.maximum(spacing, np.where(inside, depth / np.float32(focal), np.float32(0)), out=spacing)
    unseen = spacing == 0
    if np.any(unseen):
        centers = recon.camera_centers()[views].astype(np.float32)
        nearest = np.linalg.norm(points[unseen, None, :] - centers[None], axis=2).min(axis=1)
        spacing[unseen] = nearest / np.float32(np.mean(focals))
    stride = max(1.0, float(np.sqrt(grid_pixels / recon.num_points)))
    return spacing * np.float32(stride)


def novel_view_intrinsic(recon: Reconstruction, width: int, height: int, zoom_out: float = 0.5) -> np.ndarray:
    """Intrinsics of a novel view: the first registered view's focal, scaled to the output size.

    The focal scales by min(width / w, height / h) so pixels stay square and the input's field of
    view fits; it is then multiplied by `zoom_out` (0.5 shows more context, 1 keeps the FOV). The
    principal point is the output centre (width / 2, height / 2), matching the convention that
    a pixel grid spans the whole image.
    """
    if not zoom_out > 0 or not np.isfinite(zoom_out):
        raise ValueError(f"zoom_out must be positive, got {zoom_out}")
    registered = np.flatnonzero(recon.registered)
    if len(registered) == 0:
        raise ValueError("the reconstruction has no registered view to take intrinsics from")
    view = registered[0]
    source_width, source_height = recon.image_sizes[view]
    scale = min(width / source_width, height / source_height) * zoom_out
    fx, fy = recon.intrinsics[view, 0, 0], recon.intrinsics[view, 1, 1]
    return np.array([[fx * scale, 0.0, width / 2.0], [0.0, fy * scale, height / 2.0], [0.0, 0.0, 1.0]])


def synthesize_novel_view(
    recon: Reconstruction,
    extrinsic: np.ndarray,
    width: int = 512,
    height: int = 512,
    zoom_out: float = 0.5,
    point_radius_px: float | None = None,
    fill_cracks: bool = True,
) -> np.ndarray:
    """Render the reconstruction's points from `extrinsic` on white; splats sized per point.

    Without `point_radius_px` each point's splat covers its `sample_spacing` projected into this
    view, so surfaces stay closed when the camera moves closer than the input views were.
    `fill_cracks` closes the pinholes that remain where neighbouring splats do not quite meet,
    without growing silhouettes or empty regions (see the module doc).
    """
    intrinsic = novel_view_intrinsic(recon, width, height, zoom_out)
    spacing = None if point_radius_px is not None else sample_spacing(recon)
    return render_point_cloud(
        recon.points,
        recon.colors,
        extrinsic,
        intrinsic,
        width,
        height,
        point_radius_px=point_radius_px,
        point_spacing=spacing,
        fill_cracks=fill_cracks,
    )


__all__ = [
    "novel_view_intrinsic",
    "rasterize_points",
    "render_point_cloud",
    "sample_spacing",
    "synthesize_novel_view",
]
