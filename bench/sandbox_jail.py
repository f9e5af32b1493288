"""What the sandbox's OS jail costs: /v1/solve execution-stage time on a cached scene, jail on vs off.

    python -m bench.sandbox_jail [--requests 20]

One run starts Redis (unless one answers on 6379), a recon service, a scripted code model and two
agents that differ only in PYSPATIAL_SANDBOX_JAIL (required / off). The scene is reconstructed once;
then the two agents take turns on the same program, so machine load hits both alike. The figure is
the `execution_ms` each response reports (program start-up, run and its tool calls).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import uuid

import httpx

from shared.local.services import redis_answers, running_service, start_redis
from shared.wire.client import ReconClient
from tests.support.scenes import orbit_views
from tests.support.scripted_llm import start_scripted_llm

PROGRAM_REPLY = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    return pySpatial.describe_camera_motion(recon)
```"""
QUESTION = "Which way did the camera move from view 1 to view 2? A. left B. right"


def _execution_ms(url: str, scene_id: str) -> float:
    body = {"question": QUESTION, "scene_id": scene_id, "backbone": "posed-rgbd", "max_repairs": 0}
    response = httpx.post(url + "/v1/solve", json=body, timeout=120)
    response.raise_for_status()
    result = response.json()
    if result["attempts"][0]["error"] is not None:
        raise RuntimeError(result["attempts"][0]["error"])
    return result["timings"]["execution_ms"]


def _summary(values: list[float]) -> str:
    ordered = sorted(values)
    p90 = ordered[min(len(ordered) - 1, int(0.9 * len(ordered)))]
    return f"median {statistics.median(values):6.0f} ms   p90 {p90:6.0f} ms   min {ordered[0]:6.0f} ms"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bench.sandbox_jail", description=__doc__.splitlines()[0])
    parser.add_argument("--requests", type=int, default=20, help="requests per agent")
    args = parser.parse_args(argv)

    own_redis = None if redis_answers("redis://127.0.0.1:6379/0") else start_redis()
    llm = start_scripted_llm()
    recon_env = {
        "REDIS_URL": own_redis.url if own_redis else "redis://127.0.0.1:6379/0",
        "PYSPATIAL_DATA_DIR": tempfile.mkdtemp(prefix="bench-jail-"),
        "PYSPATIAL_CACHE_NAMESPACE": f"bench-{uuid.uuid4().hex[:8]}",
    }
    try:
        with running_service("services.recon.app:create_app", recon_env) as recon:
            views = orbit_views(seed=3, num_views=3)
            with ReconClient(recon.url) as client:
                cameras = {"extrinsics": views.extrinsics, "intrinsics": views.intrinsics}
                scene_id = client.upload_scene(views.pngs(), depths=views.depths, **cameras).scene_id
                client.reconstruct(scene_id, "posed-rgbd")  # cached from here on
            base_env = {
                "PYSPATIAL_RECON_URL": recon.url,
                "PYSPATIAL_CODE_MODEL": "coder",
                "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
            }
            llm.script([PROGRAM_REPLY] * (2 * args.requests + 2), model="coder")
            timings: dict[str, list[float]] = {"required": [], "off": []}
            with (
                running_service("services.agent.app:create_app", {**base_env}) as jailed,
                running_service(
                    "services.agent.app:create_app", {**base_env, "PYSPATIAL_SANDBOX_JAIL": "off"}
                ) as unjailed,
            ):
                agents = {"required": jailed.url, "off": unjailed.url}
                for url in agents.values():
                    _execution_ms(url, scene_id)  # warm-up
                for _ in range(args.requests):
                    for mode, url in agents.items():
                        timings[mode].append(_execution_ms(url, scene_id))
    finally:
        llm.stop()
        if own_redis:
            own_redis.stop()
    print(f"execution stage on a cached scene, {args.requests} requests per agent, interleaved")
    print(f"  jail off (PYSPATIAL_SANDBOX_JAIL=off)      {_summary(timings['off'])}")
    print(f"  jail on  (PYSPATIAL_SANDBOX_JAIL=required) {_summary(timings['required'])}")
    added = statistics.median(timings["required"]) - statistics.median(timings["off"])
    print(f"  the jail adds {added:.0f} ms per program (difference of medians)")
    _runner_only(args.requests)


def _runner_only(requests: int) -> None:
    """The same comparison without HTTP: run_program alone, a program without tool calls."""
    from services.agent.sandbox import SandboxLimits, run_program
    from services.agent.sandbox.jail import JailMode, probe

    source = "def program(input_scene):\n    return float(np.linalg.norm(np.eye(3)))\n"
    statuses = {"required": probe(JailMode.REQUIRED), "off": probe(JailMode.OFF)}
    timings: dict[str, list[float]] = {mode: [] for mode in statuses}
    for _ in range(requests):
        for mode, status in statuses.items():
            result = run_program(source, "q", 1, _NoTools(), SandboxLimits(), status)
            if not result.ok:
                raise RuntimeError(result.error)
            timings[mode].append(result.duration_ms)
    print(f"run_program alone (start-up, run, exit), {requests} runs each, interleaved")
    print(f"  jail off {_summary(timings['off'])}")
    print(f"  jail on  {_summary(timings['required'])}")
    added = statistics.median(timings["required"]) - statistics.median(timings["off"])
    print(f"  the jail adds {added:.0f} ms per program (difference of medians)")


class _NoTools:
    def reconstruct(self) -> dict:
        raise RuntimeError("not used")

    describe_camera_motion = synthesize_novel_view = input_image = reconstruct


if __name__ == "__main__":
    main()
