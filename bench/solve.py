"""/v1/solve latency per stage and throughput, with a scripted model, through the real stack.

    python -m bench.solve [--backbone classical] [--requests 16] [--clients 8]

Starts Redis (unless one answers on 6379), the recon and agent services and a local
OpenAI-compatible server that replays a fixed program and answer, so the figures measure this
system and not a hosted model. Cold = a scene never reconstructed; cached = the same scene again.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import uuid
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from bench.recon_cache import four_views
from shared.imaging.codecs import encode_image
from shared.local.services import redis_answers, running_service, start_redis
from shared.wire.client import AgentClient
from tests.support.scripted_llm import start_scripted_llm

PROGRAM_REPLY = """The question asks for the camera motion, so describe it.
```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.describe_camera_motion(recon)
```"""
ANSWER_REPLY = '{"reasoning": "The clue states the motion.", "answer": "B"}'
QUESTION = "Which way did the camera move from view 1 to view 2? A. left B. right C. forward D. backward"
STAGES = ("reconstruction_ms", "codegen_ms", "execution_ms", "answering_ms", "total_ms")


def _jittered(images: list[np.ndarray], seed: int) -> list[bytes]:
    """The same views with invisible noise: a new scene id, so a cold reconstruction."""
    rng = np.random.default_rng(seed)
    return [
        encode_image(np.clip(im.astype(int) + rng.integers(-1, 2, im.shape), 0, 255).astype(np.uint8))
        for im in images
    ]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bench.solve", description=__doc__.splitlines()[0])
    parser.add_argument("--backbone", default="classical")
    parser.add_argument("--requests", type=int, default=16, help="requests in the throughput run")
    parser.add_argument("--clients", type=int, default=8)
    parser.add_argument("--size", type=int, nargs=2, default=[480, 360], metavar=("W", "H"))
    args = parser.parse_args(argv)

    images = [v.rgb for v in four_views(*args.size)]
    own_redis = None if redis_answers("redis://127.0.0.1:6379/0") else start_redis()
    llm = start_scripted_llm()
    recon_env = {
        "REDIS_URL": own_redis.url if own_redis else "redis://127.0.0.1:6379/0",
        "PYSPATIAL_DATA_DIR": tempfile.mkdtemp(prefix="bench-solve-"),
        "PYSPATIAL_CACHE_NAMESPACE": f"bench-{uuid.uuid4().hex[:8]}",
    }
    try:
        with running_service("services.recon.app:create_app", recon_env) as recon:
            agent_env = {
                "PYSPATIAL_RECON_URL": recon.url,
                "PYSPATIAL_CODE_MODEL": "coder",
                "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
                "PYSPATIAL_ANSWER_MODEL": "answerer",
                "PYSPATIAL_ANSWER_MODEL_BASE_URL": llm.base_url,
            }
            with running_service("services.agent.app:create_app", agent_env) as agent_service:
                agent = AgentClient(agent_service.url)
                total = 2 + args.requests
                llm.script([PROGRAM_REPLY] * total, model="coder")
                llm.script([ANSWER_REPLY] * total, model="answerer")
                cold_images = _jittered(images, 1)
                cold = agent.solve(QUESTION, images=cold_images, backbone=args.backbone)
                cached = agent.solve(QUESTION, images=cold_images, backbone=args.backbone)

                def one(_: int):
                    started = time.perf_counter()
                    result = agent.solve(QUESTION, images=cold_images, backbone=args.backbone)
                    return time.perf_counter() - started, result

                started = time.perf_counter()
                with ThreadPoolExecutor(args.clients) as pool:
                    runs = list(pool.map(one, range(args.requests)))
                wall = time.perf_counter() - started
    finally:
        llm.stop()
        if own_redis:
            own_redis.stop()

    print(
        f"### /v1/solve per stage, scripted model, {args.backbone} backbone, 4 views {args.size[0]}x"
        f"{args.size[1]}\n"
    )
    print("| scene | " + " | ".join(s.removesuffix("_ms") + " (ms)" for s in STAGES) + " | answer |")
    print("| --- |" + " ---: |" * len(STAGES) + " --- |")
    for label, result in (("cold", cold), ("cached", cached)):
        cells = " | ".join(f"{getattr(result.timings, s):,.0f}" for s in STAGES)
        print(f"| {label} | {cells} | {result.answer} |")
    latencies = sorted(seconds for seconds, _ in runs)
    answered = sum(result.answer is not None for _, result in runs)
    print(
        f"\n### Throughput: {args.requests} requests from {args.clients} concurrent clients (cached scene)\n"
    )
    print("| requests/s | median latency (s) | p95 latency (s) | answered |")
    print("| ---: | ---: | ---: | ---: |")
    p95 = latencies[min(len(latencies) - 1, int(round(0.95 * (len(latencies) - 1))))]
    print(
        f"| {args.requests / wall:.2f} | {statistics.median(latencies):.2f} | {p95:.2f} | "
        f"{answered}/{args.requests} |"
    )


if __name__ == "__main__":
    main()
