"""Load on the real stack: /v1/solve throughput and latency percentiles, memory, health under uploads.

    python -m bench.load [--levels 4 8 16] [--requests 48] [--rss-requests 1000] [--upload-images 32]

Runs, in one process and one run so the figures compare side by side:
1. /v1/solve with fresh images (a new scene, so a cold reconstruction, every request) at each
   concurrency level, against one recon replica and against two replicas behind a real nginx
   (round-robin, separate data dirs, one Redis). Offline planner and answerer: no model in the loop.
2. RSS of the recon and agent processes before and after `--rss-requests` solves of a cached scene.
3. /healthz latency, polled every 20 ms, while one upload of `--upload-images` 4000x3000 JPEGs is
   received, decoded and stored.
"""

from __future__ import annotations

import argparse
import io
import tempfile
import threading
import time
import uuid
from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import psutil
from PIL import Image

from shared.imaging.codecs import encode_image
from shared.local.nginx import running_nginx
from shared.local.services import redis_answers, running_service, start_redis
from shared.wire.client import AgentClient
from tests.support.scenes import orbit_views

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
QUESTION = "Which way did the camera move from view 1 to view 2? A. left B. right C. forward D. backward"


def _fresh(images: list[np.ndarray], seed: int) -> list[bytes]:
    rng = np.random.default_rng(seed)
    return [
        encode_image(np.clip(im.astype(int) + rng.integers(-2, 3, im.shape), 0, 255).astype(np.uint8))
        for im in images
    ]


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q * (len(ordered) - 1))))]


def _throughput(agent_url: str, images: list[np.ndarray], clients: int, requests: int, seed: int) -> dict:
    payloads = [_fresh(images, seed + i) for i in range(requests)]

    def one(index: int) -> tuple[float, bool]:
        with AgentClient(agent_url, timeout=600) as agent:
            started = time.perf_counter()
            try:
                result = agent.solve(QUESTION, images=payloads[index])
                ok = result.answer is not None
            except Exception:  # counted as a failure in the table
                ok = False
            return time.perf_counter() - started, ok

    started = time.perf_counter()
    with ThreadPoolExecutor(clients) as pool:
        runs = list(pool.map(one, range(requests)))
    wall = time.perf_counter() - started
    latencies = [seconds for seconds, _ in runs]
    return {
        "rps": requests / wall,
        "p50": _percentile(latencies, 0.50),
        "p95": _percentile(latencies, 0.95),
        "p99": _percentile(latencies, 0.99),
        "ok": sum(ok for _, ok in runs),
        "n": requests,
    }


def _rss_mb(*pids: int) -> list[float]:
    return [psutil.Process(pid).memory_info().rss / 2**20 for pid in pids]


def _big_jpeg(width: int, height: int) -> bytes:
    """A photo-sized JPEG with real structure: a rendered room scaled up, plus sensor-like noise."""
    small = orbit_views(seed=2, num_views=1, width=400, height=300).images[0]
    image = np.asarray(Image.fromarray(small).resize((width, height), Image.BICUBIC), dtype=np.int16)
    image = np.clip(image + np.random.default_rng(0).integers(-6, 7, image.shape), 0, 255).astype(np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="JPEG", quality=90)
    return buffer.getvalue()


def _health_during_upload(recon_url: str, count: int) -> dict:
    jpeg = _big_jpeg(4000, 3000)
    files = [("images", (f"{i}.jpg", jpeg)) for i in range(count)]
    outcome: dict = {}

    def upload() -> None:
        started = time.perf_counter()
        response = httpx.post(recon_url + "/v1/scenes", files=files, timeout=600)
        outcome.update(status=response.status_code, seconds=time.perf_counter() - started)

    worker = threading.Thread(target=upload)
    latencies, idle = [], []
    with httpx.Client(timeout=60) as http:
        until = time.perf_counter() + 10  # baseline: the same polling with no upload (machine noise)
        while time.perf_counter() < until:
            started = time.perf_counter()
            http.get(recon_url + "/healthz")
            idle.append((time.perf_counter() - started) * 1e3)
            time.sleep(0.02)
        worker.start()
        while worker.is_alive():
            started = time.perf_counter()
            http.get(recon_url + "/healthz")
            latencies.append((time.perf_counter() - started) * 1e3)
            time.sleep(0.02)
    worker.join()
    return {
        **outcome,
        "mb": len(jpeg) * count / 2**20,
        "polls": len(latencies),
        "p50": _percentile(latencies, 0.5),
        "p95": _percentile(latencies, 0.95),
        "max": max(latencies),
        "idle": (_percentile(idle, 0.5), _percentile(idle, 0.95), max(idle)),
    }


def _rss_over_solves(agent_url: str, images: list[np.ndarray], pids: tuple[int, int], args) -> tuple:
    with AgentClient(agent_url, timeout=600) as agent:
        scene_id = agent.solve(QUESTION, images=_fresh(images, 1)).scene_id
    before = _rss_mb(*pids)

    def cached_solve(_: int) -> None:
        with AgentClient(agent_url, timeout=600) as agent:
            agent.solve(QUESTION, scene_id=scene_id)

    started = time.perf_counter()
    with ThreadPoolExecutor(8) as pool:
        list(pool.map(cached_solve, range(args.rss_requests)))
    return before, _rss_mb(*pids), time.perf_counter() - started


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bench.load", description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[4, 8, 16])
    parser.add_argument("--requests", type=int, default=48, help="solves per concurrency level")
    parser.add_argument("--rss-requests", type=int, default=1000)
    parser.add_argument("--upload-images", type=int, default=32)
    parser.add_argument(
        "--parts", nargs="+", choices=["solve", "rss", "health"], default=["solve", "rss", "health"]
    )
    args = parser.parse_args(argv)

    images = orbit_views(seed=5, num_views=3).images  # 160x120: the stack, not the backbone, is measured
    own_redis = None if redis_answers("redis://127.0.0.1:6379/0") else start_redis()
    redis_url = own_redis.url if own_redis else "redis://127.0.0.1:6379/0"
    namespace = f"bench-{uuid.uuid4().hex[:8]}"

    def recon_env() -> dict[str, str]:
        return {
            "REDIS_URL": redis_url,
            "PYSPATIAL_DATA_DIR": tempfile.mkdtemp(prefix="bench-load-"),
            "PYSPATIAL_CACHE_NAMESPACE": namespace,
        }

    rows, rss, health = [], None, None
    try:
        with (
            running_service(RECON_APP, recon_env()) as first,
            running_service(RECON_APP, recon_env()) as second,
            running_nginx([first.url, second.url]) as nginx,
            running_service(AGENT_APP, {"PYSPATIAL_RECON_URL": first.url}) as single_agent,
            running_service(AGENT_APP, {"PYSPATIAL_RECON_URL": nginx.url}) as balanced_agent,
        ):
            seed = 1000
            for clients in args.levels if "solve" in args.parts else []:
                for label, agent in (("1 replica", single_agent), ("2 replicas + nginx", balanced_agent)):
                    result = _throughput(agent.url, images, clients, args.requests, seed)
                    rows.append((label, clients, result))
                    seed += args.requests

            if "rss" in args.parts:
                rss = _rss_over_solves(
                    single_agent.url, images, (first.process.pid, single_agent.process.pid), args
                )
            if "health" in args.parts:
                health = _health_during_upload(second.url, args.upload_images)
    finally:
        if own_redis:
            own_redis.stop()

    if rows:
        _print_solve(rows)
    if rss:
        _print_rss(rss, args.rss_requests)
    if health:
        _print_health(health, args.upload_images)


def _print_solve(rows: list) -> None:
    print("### /v1/solve under load (fresh 3-view 160x120 scene per request, offline planner)\n")
    print("| recon | clients | requests/s | p50 (s) | p95 (s) | p99 (s) | answered |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for label, clients, r in rows:
        print(
            f"| {label} | {clients} | {r['rps']:.2f} | {r['p50']:.2f} | {r['p95']:.2f} | {r['p99']:.2f} | "
            f"{r['ok']}/{r['n']} |"
        )


def _print_rss(rss: tuple, requests: int) -> None:
    before, after, seconds = rss
    print(f"\n### RSS before/after {requests} cached-scene solves (8 clients, {seconds:.0f} s)")
    print()
    print("| process | before (MiB) | after (MiB) | growth (MiB) |")
    print("| --- | ---: | ---: | ---: |")
    for name, b, a in zip(("recon", "agent"), before, after, strict=True):
        print(f"| {name} | {b:.0f} | {a:.0f} | {a - b:+.0f} |")


def _print_health(health: dict, count: int) -> None:
    print(
        f"\n### /healthz while one upload of {count} 4000x3000 JPEGs ({health['mb']:.0f} MiB) is processed\n"
    )
    print("| /healthz polled | upload status | upload (s) | polls | p50 (ms) | p95 (ms) | max (ms) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    p50, p95, top = health["idle"]
    print(f"| 10 s before, no upload | | | | {p50:.1f} | {p95:.1f} | {top:.1f} |")
    print(
        f"| during the upload | {health['status']} | {health['seconds']:.1f} | {health['polls']} | "
        f"{health['p50']:.1f} | {health['p95']:.1f} | {health['max']:.1f} |"
    )


if __name__ == "__main__":
    main()
