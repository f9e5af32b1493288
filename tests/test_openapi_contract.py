"""The OpenAPI of both services documents exactly the status codes they answer, in the real body shape.

Every documented code of every endpoint is provoked over HTTP against real uvicorn processes (real
Redis behind recon); the codes observed per endpoint must equal the documented ones, and every
error body must be the documented `ErrorBody` ({"detail": str}).
"""

from __future__ import annotations

import base64
import io
import json
import os
import resource
import shutil
import signal
import socket
import uuid
from collections import defaultdict

import httpx
import numpy as np
import pytest

from shared.imaging.codecs import encode_image
from shared.local.services import ServiceProcess, start_service
from shared.wire.schemas import ErrorBody
from tests.support.scenes import orbit_views
from tests.test_agent_service import motion_question

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
RECON_KEY = "recon-test-key"
AGENT_KEY = "agent-test-key"
UNKNOWN_SCENE = "0" * 24
NOT_AN_IMAGE = b"this is not an image"
# Documented, but only possible where this checkout cannot be: an installation without the
# bundled example (examples/living_room) answers /v1/example with 404.
NOT_PROVOKED = {("agent", "get", "/v1/example"): {404}}


class Observer:
    """Sends requests and remembers the status codes seen per (service, method, route)."""

    def __init__(self) -> None:
        self.seen: dict[tuple[str, str, str], set[int]] = defaultdict(set)

    def call(
        self, service: str, method: str, route: str, url: str, expected: int, **kwargs
    ) -> httpx.Response:
        response = httpx.request(method, url, timeout=60, **kwargs)
        assert response.status_code == expected, (method, url, response.status_code, response.text[:300])
        if expected >= 400 and route != "/readyz":
            ErrorBody.model_validate(response.json())  # the documented error shape, nothing else
        self.seen[(service, method.lower(), route)].add(expected)
        return response


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=7, num_views=3)


def recon_env(tmp_path_factory, redis_url, **extra) -> dict[str, str]:
    return {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("recon")),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"contract-{uuid.uuid4().hex[:8]}",
        **extra,
    }


def small_file_size_limit() -> None:
    """In the service process: files may not grow past 64 KiB (EFBIG, as on a full disk)."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a failing write instead of a killed process
    resource.setrlimit(resource.RLIMIT_FSIZE, (64 * 1024, 64 * 1024))


def start_all(app: str, environments: dict[str, dict]) -> dict[str, ServiceProcess]:
    """Start the processes one after the other; if one fails, stop the others and raise."""
    started = {}
    try:
        for name, env in environments.items():
            started[name] = start_service(app, env)
    except RuntimeError:
        for service in started.values():
            service.stop()
        raise
    return started


@pytest.fixture(scope="module")
def stack(tmp_path_factory, redis_url):
    """Recons (keyed and ready; rate-limited; not ready) and agents in front of them."""
    broken = tmp_path_factory.mktemp("weights") / "broken.safetensors"
    broken.write_bytes(b"not a checkpoint")
    recons = {
        "recon": recon_env(
            tmp_path_factory,
            redis_url,
            PYSPATIAL_BACKBONE="posed-rgbd",
            PYSPATIAL_API_KEYS=RECON_KEY,
            PYSPATIAL_MAX_REQUEST_BYTES="3000000",
            # This test sends bad keys on purpose to see each route's 401; the throttle of failed
            # authentications is provoked on `recon_limited`, where it is counted exactly.
            PYSPATIAL_AUTH_FAILURES_PER_MINUTE="0",
        ),
        "recon_limited": recon_env(
            tmp_path_factory,
            redis_url,
            PYSPATIAL_API_KEYS=RECON_KEY,
            PYSPATIAL_RATE_LIMIT_PER_MINUTE="1",
            PYSPATIAL_RATE_LIMIT_BURST="1",
            PYSPATIAL_AUTH_FAILURES_PER_MINUTE="1",
        ),
        # A checkpoint that is there but broken: the backbone cannot be built, 503s (weights that are
        # simply absent are the caller's 409 instead, provoked on `recon` by naming pi3x).
        "recon_unready": recon_env(
            tmp_path_factory, redis_url, PYSPATIAL_BACKBONE="vggt", PYSPATIAL_VGGT_CHECKPOINT=str(broken)
        ),
    }
    services = {}
    # A port bound but never listening: connections to it are refused for as long as it is held.
    nothing = socket.socket()
    nothing.bind(("127.0.0.1", 0))
    try:
        services.update(start_all(RECON_APP, recons))
        storage_dir = tmp_path_factory.mktemp("storage")
        services["recon_storage"] = start_service(
            RECON_APP, {"PYSPATIAL_DATA_DIR": str(storage_dir)}, preexec_fn=small_file_size_limit
        )
        recon_url, unready_url = services["recon"].url, services["recon_unready"].url
        limited_url = services["recon_limited"].url
        agents = {
            "agent": {
                "PYSPATIAL_RECON_URL": recon_url,
                "PYSPATIAL_RECON_API_KEY": RECON_KEY,
                "PYSPATIAL_API_KEYS": AGENT_KEY,
                "PYSPATIAL_MAX_REQUEST_BYTES": "3000000",
                "PYSPATIAL_AUTH_FAILURES_PER_MINUTE": "0",  # each guarded route's 401 is provoked
            },
            # recon refuses it (no key): the stack's fault, a 502
            "agent_without_recon_key": {"PYSPATIAL_RECON_URL": recon_url},
            # recon refuses it, then throttles its failed authentications: still the key, a 502
            "agent_throttled_by_recon": {"PYSPATIAL_RECON_URL": limited_url},
            # recon rate-limits its (valid) key: overloaded for now, a 503 with recon's wait
            "agent_of_limited_recon": {
                "PYSPATIAL_RECON_URL": limited_url,
                "PYSPATIAL_RECON_API_KEY": RECON_KEY,
            },
            # recon not ready (503) or, stopped, hung (504)
            "agent_of_unready": {
                "PYSPATIAL_RECON_URL": unready_url,
                "PYSPATIAL_RECON_TIMEOUT_S": "2",
                "PYSPATIAL_READINESS_TIMEOUT_S": "1",
            },
            "agent_of_nothing": {"PYSPATIAL_RECON_URL": f"http://127.0.0.1:{nothing.getsockname()[1]}"},
            "agent_limited": {
                "PYSPATIAL_RECON_URL": recon_url,
                "PYSPATIAL_RECON_API_KEY": RECON_KEY,
                "PYSPATIAL_RATE_LIMIT_PER_MINUTE": "1",
                "PYSPATIAL_RATE_LIMIT_BURST": "1",
            },
        }
        services.update(start_all(AGENT_APP, agents))
        yield {**services, "recon_storage_dir": storage_dir}
    finally:
        for service in services.values():
            service.stop()
        nothing.close()


def documented_codes(openapi: dict) -> dict[tuple[str, str], set[int]]:
    return {
        (method, path): {int(code) for code in operation["responses"]}
        for path, operations in openapi["paths"].items()
        for method, operation in operations.items()
    }


def upload_files(views) -> dict:
    files = [("images", (f"{i}.png", png)) for i, png in enumerate(views.pngs())]
    for i, depth in enumerate(views.depths):
        buffer = io.BytesIO()
        np.save(buffer, depth.astype(np.float32))
        files.append(("depths", (f"{i}.npy", buffer.getvalue())))
    data = {
        "extrinsics": json.dumps(views.extrinsics.tolist()),
        "intrinsics": json.dumps(views.intrinsics.tolist()),
    }
    return {"files": files, "data": data}


def exercise_recon(observe: Observer, stack, views) -> None:
    base, limited, unready = stack["recon"].url, stack["recon_limited"].url, stack["recon_unready"].url
    key = {"Authorization": f"Bearer {RECON_KEY}"}

    def recon(method, route, path, expected, url=base, **kwargs):
        return observe.call("recon", method, route, url + path, expected, **kwargs)

    recon("GET", "/healthz", "/healthz", 200)
    recon("GET", "/readyz", "/readyz", 200)
    recon("GET", "/readyz", "/readyz", 503, url=unready)
    scene = recon("POST", "/v1/scenes", "/v1/scenes", 201, headers=key, **upload_files(views)).json()[
        "scene_id"
    ]
    recon("POST", "/v1/scenes", "/v1/scenes", 200, headers=key, **upload_files(views))
    recon("POST", "/v1/scenes", "/v1/scenes", 400, headers=key, files=[("images", ("x.png", NOT_AN_IMAGE))])
    recon("POST", "/v1/scenes", "/v1/scenes", 422, headers=key, json={"images": []})
    over = {**key, "content-type": "application/json"}
    recon("POST", "/v1/scenes", "/v1/scenes", 413, headers=over, content=b" " * 3_100_000)
    # Storage faults: a full disk is a 507, an unwritable data dir a 503.
    storage = stack["recon_storage"]
    noise = np.random.default_rng(0).integers(0, 256, (160, 200, 3), dtype=np.uint8)  # ~96 KB as PNG
    big = [("images", ("noise.png", encode_image(noise)))]
    recon("POST", "/v1/scenes", "/v1/scenes", 507, url=storage.url, files=big)
    shutil.rmtree(stack["recon_storage_dir"] / "scenes")
    (stack["recon_storage_dir"] / "scenes").write_text("a file where the scenes directory should be")
    small = [("images", ("0.png", views.pngs()[0]))]
    recon("POST", "/v1/scenes", "/v1/scenes", 503, url=storage.url, files=small)
    unready_scene = recon(
        "POST", "/v1/scenes", "/v1/scenes", 201, url=unready, files=[("images", ("0.png", views.pngs()[0]))]
    ).json()["scene_id"]

    pose = views.extrinsics[0].tolist()
    routes = [  # (method, route, path for a scene, body for a scene, how to make it a 422)
        ("GET", "/v1/backbones", lambda s: "/v1/backbones", None, None),
        ("GET", "/v1/scenes/{scene_id}", lambda s: f"/v1/scenes/{s}", None, None),
        (
            "GET",
            "/v1/scenes/{scene_id}/images/{index}",
            lambda s: f"/v1/scenes/{s}/images/0",
            None,
            lambda s: ("GET", f"/v1/scenes/{s}/images/first", None),
        ),
        (
            "POST",
            "/v1/scenes/{scene_id}/reconstruct",
            lambda s: f"/v1/scenes/{s}/reconstruct",
            {},
            lambda s: ("POST", f"/v1/scenes/{s}/reconstruct", {"backbone": "nerf"}),
        ),
        (
            "GET",
            "/v1/scenes/{scene_id}/reconstruction",
            lambda s: f"/v1/scenes/{s}/reconstruction",
            None,
            lambda s: ("GET", f"/v1/scenes/{s}/reconstruction?format=obj", None),
        ),
        (
            "GET",
            "/v1/scenes/{scene_id}/points",
            lambda s: f"/v1/scenes/{s}/points?max_points=50",
            None,
            lambda s: ("GET", f"/v1/scenes/{s}/points?max_points=0", None),
        ),
        (
            "POST",
            "/v1/render",
            lambda s: "/v1/render",
            lambda s: {"scene_id": s, "extrinsic": pose, "width": 32, "height": 32},
            lambda s: ("POST", "/v1/render", {"scene_id": s, "extrinsic": [[1.0]]}),
        ),
        (
            "POST",
            "/v1/camera-motion",
            lambda s: "/v1/camera-motion",
            lambda s: {"scene_id": s},
            lambda s: ("POST", "/v1/camera-motion", {"scene_id": s, "pairs": [[1, 9]]}),
        ),
    ]

    def send(method, route, path, body, expected, url=base, headers=key):
        kwargs = {"json": body} if body is not None else {}
        return recon(method, route, path, expected, url=url, headers=headers, **kwargs)

    recon("GET", "/v1/backbones", "/v1/backbones", 200, url=limited, headers=key)  # spends the burst
    for method, route, path, body, bad in routes:
        scene_body = body(scene) if callable(body) else body
        send(method, route, path(scene), scene_body, 200)
        send(method, route, path(scene), scene_body, 401, headers={})
        send(method, route, path(scene), scene_body, 429, url=limited)
        if "{scene_id}" in route or route in ("/v1/render", "/v1/camera-motion"):
            missing_body = body(UNKNOWN_SCENE) if callable(body) else body
            send(method, route, path(UNKNOWN_SCENE), missing_body, 404)
        if bad is not None:
            bad_method, bad_path, bad_body = bad(scene)
            send(bad_method, route, bad_path, bad_body, 422)
        if route not in ("/v1/backbones", "/v1/scenes/{scene_id}", "/v1/scenes/{scene_id}/images/{index}"):
            unready_body = body(unready_scene) if callable(body) else body
            send(method, route, path(unready_scene), unready_body, 503, url=unready, headers={})
            # Naming a backbone whose weights are not present: 409 with the command that gets them.
            if method == "GET":
                send(
                    method,
                    route,
                    path(scene) + ("&" if "?" in path(scene) else "?") + "backbone=pi3x",
                    None,
                    409,
                )
            else:
                send(method, route, path(scene), {**(scene_body or {}), "backbone": "pi3x"}, 409)
    recon("POST", "/v1/scenes", "/v1/scenes", 401, **upload_files(views))
    recon("POST", "/v1/scenes", "/v1/scenes", 429, url=limited, headers=key, **upload_files(views))


def exercise_agent(observe: Observer, stack, views, scene_id: str) -> None:
    key = {"Authorization": f"Bearer {AGENT_KEY}"}
    question, _ = motion_question(views)
    solve_body = {"question": question, "scene_id": scene_id, "backbone": "posed-rgbd"}

    def agent(method, route, path, expected, name="agent", headers=key, **kwargs):
        url = stack[name].url + path
        return observe.call("agent", method, route, url, expected, headers=headers, **kwargs)

    def solve(expected, name="agent", headers=key, **kwargs):
        return agent("POST", "/v1/solve", "/v1/solve", expected, name=name, headers=headers, **kwargs)

    agent("GET", "/healthz", "/healthz", 200)
    agent("GET", "/readyz", "/readyz", 200)
    agent("GET", "/readyz", "/readyz", 503, name="agent_of_unready")
    solve(200, json=solve_body)
    solve(400, json={"question": question, "images": ["bm90IGFuIGltYWdl"]})
    solve(404, json={**solve_body, "scene_id": UNKNOWN_SCENE})
    solve(413, headers={**key, "content-type": "application/json"}, content=b" " * 3_100_000)
    solve(422, json={**solve_body, "scene_id": "../../healthz"})
    refused = solve(409, json={**solve_body, "backbone": "pi3x"})  # its weights are not present
    assert "run `pyspatial weights pull pi3x`" in refused.json()["detail"]
    pngs = [base64.b64encode(png).decode() for png in views.pngs()]
    solve(503, name="agent_of_unready", headers={}, json={"question": question, "images": pngs})

    route_body = {"scene_id": scene_id, "backbone": "posed-rgbd", "goal": {"point_start_camera": [0, 0, 0]}}

    def plan(expected, **kwargs):
        return agent("POST", "/v1/route", "/v1/route", expected, **kwargs)

    plan(200, json=route_body)
    plan(400, json={"images": ["bm90IGFuIGltYWdl"], "goal": route_body["goal"]})
    plan(404, json={**route_body, "scene_id": UNKNOWN_SCENE})
    plan(413, headers={**key, "content-type": "application/json"}, content=b" " * 3_100_000)
    plan(422, json={**route_body, "goal": {}})
    plan(409, json={**route_body, "backbone": "pi3x"})

    points = "/v1/scenes/{scene_id}/points"
    agent("GET", points, f"/v1/scenes/{scene_id}/points?max_points=50", 200)
    agent("GET", points, f"/v1/scenes/{UNKNOWN_SCENE}/points", 404)
    agent("GET", points, f"/v1/scenes/{scene_id}/points?backbone=pi3x", 409)
    agent("GET", points, "/v1/scenes/%23x/points", 422)  # "#x"
    download = "/v1/scenes/{scene_id}/reconstruction"
    agent("GET", download, f"/v1/scenes/{scene_id}/reconstruction?format=ply&backbone=posed-rgbd", 200)
    agent("GET", download, f"/v1/scenes/{UNKNOWN_SCENE}/reconstruction", 404)
    agent("GET", download, f"/v1/scenes/{scene_id}/reconstruction?format=obj", 422)
    agent("GET", "/v1/backbones", "/v1/backbones", 200)
    examples = agent("GET", "/v1/examples", "/v1/examples", 200).json()["examples"]
    photo = "/v1/examples/{name}/images/{file}"
    agent("GET", photo, examples[0]["images"][0], 200)
    agent("GET", photo, "/v1/examples/living_room/images/nothing.png", 404)
    agent("GET", photo, "/v1/examples/%C2%84/images/0", 422)  # found by bench.fuzz (schemathesis)
    thumbnail = "/v1/examples/{name}/thumbnail"
    agent("GET", thumbnail, examples[0]["thumbnail"], 200)
    agent("GET", thumbnail, "/v1/examples/nothing/thumbnail", 404)
    agent("GET", thumbnail, "/v1/examples/Not-A-Name/thumbnail", 422)
    agent("GET", "/v1/example", "/v1/example", 200)
    agent("GET", "/v1/example/images/{name}", "/v1/example/images/nothing.png", 404)
    image = agent("GET", "/v1/example", "/v1/example", 200).json()["images"][0]
    agent("GET", "/v1/example/images/{name}", image, 200)

    # Every guarded route: 401 without a key, 429 over the rate, and the gateway statuses where
    # the route depends on recon (502 recon refuses us, 503 recon down, 504 recon hung).
    guarded = [
        ("POST", "/v1/solve", "/v1/solve", {"json": solve_body}),
        ("POST", "/v1/route", "/v1/route", {"json": route_body}),
        ("GET", points, f"/v1/scenes/{scene_id}/points", {}),
        ("GET", "/v1/backbones", "/v1/backbones", {}),
        ("GET", download, f"/v1/scenes/{scene_id}/reconstruction?backbone=posed-rgbd", {}),
        ("GET", "/v1/examples", "/v1/examples", {}),
        ("GET", photo, examples[0]["images"][0], {}),
        ("GET", thumbnail, examples[0]["thumbnail"], {}),
        ("GET", "/v1/example", "/v1/example", {}),
        ("GET", "/v1/example/images/{name}", image, {}),
    ]
    agent("GET", "/v1/backbones", "/v1/backbones", 200, name="agent_limited")  # spends the burst
    for method, route, path, kwargs in guarded:
        agent(method, route, path, 401, headers={}, **kwargs)
        agent(method, route, path, 429, name="agent_limited", headers={}, **kwargs)
        if route in ("/v1/solve", "/v1/route", points, "/v1/backbones", download):
            agent(method, route, path, 502, name="agent_without_recon_key", headers={}, **kwargs)
            agent(method, route, path, 503, name="agent_of_nothing", headers={}, **kwargs)
    refused_key_when_recon_throttles(agent, stack)
    process = stack["recon_unready"].process
    os.kill(process.pid, signal.SIGSTOP)  # a hung recon: connections are accepted, nothing answers
    try:
        for method, route, path, kwargs in guarded[:5]:
            agent(method, route, path, 504, name="agent_of_unready", headers={}, **kwargs)
    finally:
        os.kill(process.pid, signal.SIGCONT)


def refused_key_when_recon_throttles(agent, stack) -> None:
    """Recon throttling the agent tells the agent's fault (its key) from overload (its rate)."""
    # A keyless agent in front of recon_limited (one failed authentication a minute): the first
    # call is recon's 401, the second recon's 429; both are the agent's misconfigured key, a 502.
    for recon_answered in ("missing bearer API key", "too many failed authentications"):
        refused = agent(
            "GET", "/v1/backbones", "/v1/backbones", 502, name="agent_throttled_by_recon", headers={}
        )
        detail = refused.json()["detail"]
        assert "reconstruction service refused the agent's own API key" in detail and recon_answered in detail
    # An agent with the right key, over recon_limited's rate (its bucket spent just now): a 503
    # with recon's own wait, not the default one.
    key = {"Authorization": f"Bearer {RECON_KEY}"}
    httpx.get(stack["recon_limited"].url + "/v1/backbones", headers=key, timeout=60)
    limited = agent("GET", "/v1/backbones", "/v1/backbones", 503, name="agent_of_limited_recon", headers={})
    assert "rate limit exceeded" in limited.json()["detail"]
    assert int(limited.headers["retry-after"]) > 30  # one request a minute: recon asks ~60 s


def test_documented_status_codes_are_exactly_the_observed_ones(stack, views):
    observe = Observer()
    exercise_recon(observe, stack, views)
    headers = {"Authorization": f"Bearer {RECON_KEY}"}
    scene_id = httpx.post(stack["recon"].url + "/v1/scenes", headers=headers, **upload_files(views)).json()[
        "scene_id"
    ]
    exercise_agent(observe, stack, views, scene_id)
    for service, url in (("recon", stack["recon_unready"].url), ("agent", stack["agent"].url)):
        openapi = httpx.get(url + "/openapi.json").json()
        documented = documented_codes(openapi)
        observed = {(m, route): codes for (s, m, route), codes in observe.seen.items() if s == service}
        assert observed.keys() == documented.keys(), f"{service}: endpoints differ"
        for endpoint, codes in documented.items():
            expected = codes - NOT_PROVOKED.get((service, *endpoint), set())
            assert observed[endpoint] == expected, f"{service} {endpoint}: documented {codes}"
        schemas = openapi["components"]["schemas"]
        assert "HTTPValidationError" not in schemas and set(schemas["ErrorBody"]["required"]) == {"detail"}
        for endpoint, codes in documented.items():
            method, path = endpoint
            for code in codes - {200, 201}:
                if path != "/readyz":
                    content = openapi["paths"][path][method]["responses"][str(code)]["content"]
                    assert content["application/json"]["schema"]["$ref"].endswith("/ErrorBody")
