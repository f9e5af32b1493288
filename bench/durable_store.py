"""What the store of record costs and saves: uploads with and without it, reads after Redis forgot.

    python -m bench.durable_store [--scenes 10] [--size 320 240]

Starts a throwaway redis-server and two recon replicas (own data dirs, one store dir) as real
processes. Replica A takes the uploads and reconstructs them; replica B, which has seen none of
them, then reads each scene (info) and its reconstruction (camera motion) by id: once while Redis
has them, once after FLUSHALL (so from the store). Without a store, the second pass is all 404s.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import tempfile
import time
import uuid
from pathlib import Path

import numpy as np
import redis

from shared.imaging.codecs import encode_image
from shared.local.services import running_service, start_redis
from shared.synthetic import default_intrinsic, generate_scene, look_at, render_view
from shared.wire.client import ReconClient, ServiceError

RECON_APP = "services.recon.app:create_app"


def noisy_views(width: int, height: int, seed: int) -> list[bytes]:
    """Three views of a synthetic room with a little noise: a new scene per seed."""
    scene = generate_scene(5)
    centre = scene.room_centre.copy()
    centre[2] = 0.6
    intrinsic = default_intrinsic(width, height, 60.0)
    rng = np.random.default_rng(seed)
    files = []
    for index in range(3):
        angle = np.radians(-90.0 + 20.0 * index)
        eye = centre + 1.6 * np.array([np.cos(angle), np.sin(angle), 0.0])
        eye[2] = 1.4
        rgb = render_view(scene, look_at(eye, centre), intrinsic, width, height).rgb
        noisy = np.clip(rgb.astype(int) + rng.integers(-2, 3, rgb.shape), 0, 255).astype(np.uint8)
        files.append(encode_image(noisy, "png"))
    return files


def _timed(call) -> tuple[float, bool]:
    started = time.perf_counter()
    try:
        call()
    except ServiceError:
        return (time.perf_counter() - started) * 1e3, False
    return (time.perf_counter() - started) * 1e3, True


def run(with_store: bool, uploads: list[list[bytes]]) -> dict:
    root = Path(tempfile.mkdtemp(prefix="bench-durable-"))
    server = start_redis()
    namespace = f"bench-{uuid.uuid4().hex[:8]}"
    env = {"REDIS_URL": server.url, "PYSPATIAL_CACHE_NAMESPACE": namespace}
    if with_store:
        env["PYSPATIAL_STORE_DIR"] = str(root / "store")
    result: dict = {"store": with_store}
    try:
        with contextlib.ExitStack() as stack:
            first, second = (
                stack.enter_context(running_service(RECON_APP, {**env, "PYSPATIAL_DATA_DIR": str(root / n)}))
                for n in "ab"
            )
            a = stack.enter_context(ReconClient(first.url, timeout=300))
            b = stack.enter_context(ReconClient(second.url, timeout=300))
            ids, upload_ms = [], []
            for files in uploads:
                started = time.perf_counter()
                ids.append(a.upload_scene(files).scene_id)
                upload_ms.append((time.perf_counter() - started) * 1e3)
                a.reconstruct(ids[-1])
            result["upload_ms"] = statistics.median(upload_ms)
            half = len(ids) // 2
            for label, chosen in (("from_redis", ids[:half]), ("after_flushall", ids[half:])):
                if label == "after_flushall":
                    redis.Redis.from_url(server.url).flushall()
                reads = [_timed(lambda i=i: (b.scene_info(i), b.camera_motion(i, [(1, 2)]))) for i in chosen]
                result[f"{label}_ms"] = statistics.median(ms for ms, _ in reads)
                result[f"{label}_failed"] = sum(not ok for _, ok in reads)
    finally:
        server.stop()
    return result


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bench.durable_store", description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=10)
    parser.add_argument("--size", type=int, nargs=2, default=[320, 240], metavar=("W", "H"))
    args = parser.parse_args(argv)
    uploads = [noisy_views(*args.size, seed) for seed in range(args.scenes)]
    print(
        "| store | upload (median ms) | B reads, Redis has it (ms) | B reads after FLUSHALL (ms) "
        "| failed after FLUSHALL |"
    )
    print("| --- | ---: | ---: | ---: | ---: |")
    for with_store in (False, True):
        row = run(with_store, uploads)
        half = args.scenes - args.scenes // 2
        name = "PYSPATIAL_STORE_DIR" if with_store else "none (Redis only)"
        print(
            f"| {name} | {row['upload_ms']:.0f} | {row['from_redis_ms']:.0f} | "
            f"{row['after_flushall_ms']:.0f} | {row['after_flushall_failed']}/{half} |"
        )


if __name__ == "__main__":
    main()
