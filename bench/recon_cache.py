"""Reconstruct a 4-view scene cold, then from the cache, through the real service over HTTP.

    python -m bench.recon_cache [--backbones classical posed-rgbd] [--repeats 20] [--size 480 360]

Starts a redis-server and the recon service as real processes; the figures include HTTP and
(de)serialization, as a client sees them.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import uuid

import numpy as np

from shared.imaging.codecs import encode_image
from shared.local.services import redis_answers, running_service, start_redis
from shared.synthetic import default_intrinsic, generate_scene, look_at, render_view
from shared.wire.client import ReconClient


def four_views(width: int, height: int, seed: int = 11):
    """Four views on an arc around the room centre, 15 degrees apart, at eye height."""
    scene = generate_scene(seed)
    centre = scene.room_centre.copy()
    centre[2] = 0.6
    intrinsic = default_intrinsic(width, height, 60.0)
    views = []
    for index in range(4):
        angle = np.radians(-90.0 + 15.0 * index)
        eye = centre + 1.8 * np.array([np.cos(angle), np.sin(angle), 0.0])
        eye[2] = 1.4
        views.append(render_view(scene, look_at(eye, centre), intrinsic, width, height))
    return views


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bench.recon_cache", description=__doc__.splitlines()[0])
    parser.add_argument("--backbones", nargs="+", default=["classical", "posed-rgbd"])
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--size", type=int, nargs=2, default=[480, 360], metavar=("W", "H"))
    args = parser.parse_args(argv)

    views = four_views(*args.size)
    own_redis = None if redis_answers("redis://127.0.0.1:6379/0") else start_redis()
    redis_url = own_redis.url if own_redis else "redis://127.0.0.1:6379/0"
    env = {
        "REDIS_URL": redis_url,
        "PYSPATIAL_DATA_DIR": tempfile.mkdtemp(prefix="bench-recon-"),
        "PYSPATIAL_CACHE_NAMESPACE": f"bench-{uuid.uuid4().hex[:8]}",
    }
    rows = []
    try:
        with (
            running_service("services.recon.app:create_app", env) as service,
            ReconClient(service.url) as client,
        ):
            scene = client.upload_scene(
                [encode_image(v.rgb) for v in views],
                depths=[v.depth for v in views],
                extrinsics=np.stack([v.extrinsic for v in views]),
                intrinsics=np.stack([v.intrinsic for v in views]),
            )
            for backbone in args.backbones:
                started = time.perf_counter()
                cold = client.reconstruct(scene.scene_id, backbone)
                cold_ms = (time.perf_counter() - started) * 1e3
                hits = []
                for _ in range(args.repeats):
                    started = time.perf_counter()
                    summary = client.reconstruct(scene.scene_id, backbone)
                    hits.append((time.perf_counter() - started) * 1e3)
                    assert summary.cached
                hit_ms = statistics.median(hits)
                rows.append((backbone, cold.num_points, cold_ms, hit_ms, cold_ms / hit_ms))
    finally:
        if own_redis:
            own_redis.stop()

    width, height = args.size
    print(
        f"### Reconstruct: cold vs cache hit (4 views, {width}x{height}, HTTP + Redis, median of "
        f"{args.repeats} hits)\n"
    )
    print("| backbone | points | cold (ms) | cache hit (ms) | cold / hit |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for backbone, points, cold_ms, hit_ms, ratio in rows:
        print(f"| {backbone} | {points:,} | {cold_ms:,.0f} | {hit_ms:.1f} | {ratio:,.0f}x |")


if __name__ == "__main__":
    main()
