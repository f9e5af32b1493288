"""Which stage of the classical backbone loses each unplaced view of a ring's subsets.

    .venv/bin/python -m bench.ring_stages --ring FOLDER [--starts ...] [--spacings 7.7 23]
        [--views 4] [--no-focal]

Per subset: keypoints per view (features), per pair the ratio-tested matches, the two-view fit's
inliers and its rotation error against the truth (two-view geometry, with the true intrinsics, or
the backbone's field-of-view prior with --no-focal), then the full reconstruction: the views it
placed, and for every other view the reason it gives (registration or verification). A view is
lost at "features" when it has under MIN_FEATURES keypoints, at "matches" when no pair of it has
two-view inliers, at "registration" when the mapper never placed it (the reason says too few
reliable matches) and at "verification" when it was placed and then refused.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bench.ring_data import load_ring
from bench.templering import SPACINGS
from bench.templering_colmap import default_starts, plan_subsets
from bench.templering_data import realdata_dir, relative_pose, rotation_error_deg
from services.recon.backbones.base import BackboneError
from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.backbone import MIN_FEATURES
from services.recon.backbones.classical.features import match_features
from services.recon.backbones.classical.solve import relate_pairs


def stages(ring, images: list[int], given: bool) -> list[str]:
    backbone = ClassicalBackbone()
    pictures = [ring.image(number) for number in images]
    truth = [ring.views[number - 1].extrinsic for number in images]
    intrinsics = [ring.views[number - 1].intrinsic for number in images] if given else None
    prepared = [
        backbone._prepare(i, picture, backbone.fov_deg, intrinsics[i] if intrinsics else None)
        for i, picture in enumerate(pictures)
    ]
    keys = [(a, b) for a in range(len(images)) for b in range(a + 1, len(images))]
    matches = {key: match_features(prepared[key[0]].features, prepared[key[1]].features) for key in keys}
    # As the backbone does: a dark view's tilts only where no pair ties it well.
    prepared, matches = backbone._tilts_where_needed(prepared, list(range(len(images))), matches)
    lines = [f"{images} keypoints " + " ".join(str(len(view.features)) for view in prepared)]
    pairs = relate_pairs(
        [view.features.keypoints for view in prepared], [view.intrinsic for view in prepared], matches
    )
    for key in keys:
        pair = pairs.get(key)
        if pair is None:
            lines.append(f"  pair {images[key[0]]}-{images[key[1]]}: {len(matches[key])} matches, no fit")
            continue
        true_rotation, _ = relative_pose(truth[key[0]], truth[key[1]])
        error = rotation_error_deg(pair.rotation, true_rotation)
        lines.append(
            f"  pair {images[key[0]]}-{images[key[1]]}: {len(matches[key])} matches, "
            f"{len(pair.matches)} inliers ({pair.model}), rotation {error:.2f} deg off, "
            f"parallax {pair.median_parallax_deg:.1f} deg"
        )
    try:
        result = backbone.reconstruct(pictures, intrinsics=intrinsics)
    except BackboneError as error:
        lines.append(f"  refused: {error}")
        return lines
    for index, number in enumerate(images):
        if len(prepared[index].features) < MIN_FEATURES:
            stage = "features"
        elif not any(index in key for key in pairs):
            stage = "matches / two-view geometry"
        elif result.registered[index]:
            continue
        else:
            reason = result.view_confidence[index].unregistered_reason or ""
            stage = "registration" if "reliable matches" in reason else "verification"
            stage += f" ({reason})"
        lines.append(f"  view {number} lost at {stage}")
    if result.focal_hypotheses is not None:
        lines.append("  solved over focal hypotheses (no claimed pose)")
    lines.append(f"  placed {int(result.registered.sum())}/{len(images)}")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--ring", type=Path)
    parser.add_argument("--starts", type=int, nargs="+")
    parser.add_argument("--spacings", nargs="+", default=["7.7", "23"], choices=sorted(SPACINGS))
    parser.add_argument("--views", type=int, default=4)
    parser.add_argument("--no-focal", action="store_true")
    args = parser.parse_args(argv)
    folder = args.ring or (realdata_dir() / "templeRing")
    ring = load_ring(folder)
    for images in plan_subsets(ring, args.starts or default_starts(ring), args.spacings, args.views):
        print("\n".join(stages(ring, images, not args.no_focal)), flush=True)


if __name__ == "__main__":
    main()
