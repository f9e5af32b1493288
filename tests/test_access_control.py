"""API keys, per-key rate limits, CORS and the /docs switch of both services, over real HTTP.

The agent reaches a keyed recon service only with the key it is configured with.
"""

from __future__ import annotations

import uuid

import httpx
import pytest

from shared.local.services import running_service
from shared.wire.client import ReconClient
from tests.support.scenes import orbit_views
from tests.test_agent_service import motion_question

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
ALLOWED_ORIGIN = "https://app.example"


@pytest.fixture(scope="module")
def guarded_recon(tmp_path_factory, redis_url):
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("recon")),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"access-{uuid.uuid4().hex[:8]}",
        "PYSPATIAL_BACKBONE": "posed-rgbd",
        "PYSPATIAL_API_KEYS": "alpha-key, beta-key, agent-to-recon-key",
        "PYSPATIAL_RATE_LIMIT_PER_MINUTE": "30",
        "PYSPATIAL_RATE_LIMIT_BURST": "20",  # a solve makes about 8 recon calls
        "PYSPATIAL_CORS_ORIGINS": ALLOWED_ORIGIN,
        "PYSPATIAL_DOCS_ENABLED": "false",
    }
    with running_service(RECON_APP, env) as service:
        yield service


@pytest.fixture(scope="module")
def open_recon(tmp_path_factory):
    with running_service(RECON_APP, {"PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("open"))}) as service:
        yield service


def bearer(key: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {key}"}


def test_probes_stay_open_and_the_api_needs_a_key(guarded_recon):
    with httpx.Client(base_url=guarded_recon.url, timeout=30) as client:
        assert client.get("/healthz").status_code == 200
        assert client.get("/readyz").status_code == 200
        missing = client.get("/v1/backbones")
        assert missing.status_code == 401 and "missing bearer API key" in missing.json()["detail"]
        assert missing.headers["www-authenticate"].startswith("Bearer")
        wrong = client.get("/v1/backbones", headers=bearer("gamma-key"))
        assert wrong.status_code == 401 and "invalid API key" in wrong.json()["detail"]
        basic = client.get("/v1/backbones", headers={"Authorization": "Basic YWxwaGEta2V5"})
        assert basic.status_code == 401
        assert client.get("/v1/backbones", headers=bearer("alpha-key")).status_code == 200


def test_rate_limit_is_per_key_with_retry_after(guarded_recon):
    with httpx.Client(base_url=guarded_recon.url, timeout=30) as client:
        statuses = [client.get("/v1/backbones", headers=bearer("beta-key")).status_code for _ in range(22)]
        assert statuses[:20] == [200] * 20 and 429 in statuses[20:], statuses
        limited = client.get("/v1/backbones", headers=bearer("beta-key"))
        assert limited.status_code == 429 and "rate limit" in limited.json()["detail"]
        assert 1 <= int(limited.headers["retry-after"]) <= 2  # 30/min: one token every 2 s
        # Another key has its own bucket, and the probes are never limited.
        assert client.get("/v1/backbones", headers=bearer("alpha-key")).status_code == 200
        assert all(client.get("/healthz").status_code == 200 for _ in range(8))


def test_cors_allows_only_the_configured_origin(guarded_recon, open_recon):
    preflight = {
        "Origin": ALLOWED_ORIGIN,
        "Access-Control-Request-Method": "POST",
        "Access-Control-Request-Headers": "authorization, content-type",
    }
    with httpx.Client(base_url=guarded_recon.url, timeout=30) as client:
        allowed = client.options("/v1/scenes", headers=preflight)  # no key: preflights carry none
        assert allowed.status_code == 200
        assert allowed.headers["access-control-allow-origin"] == ALLOWED_ORIGIN
        assert "authorization" in allowed.headers["access-control-allow-headers"].lower()
        other = client.options("/v1/scenes", headers={**preflight, "Origin": "https://evil.example"})
        assert other.status_code == 400 and "access-control-allow-origin" not in other.headers
        simple = client.get("/v1/backbones", headers={"Origin": ALLOWED_ORIGIN, **bearer("alpha-key")})
        assert simple.headers["access-control-allow-origin"] == ALLOWED_ORIGIN
    # Off by default: no CORS header for any origin.
    response = httpx.get(open_recon.url + "/v1/backbones", headers={"Origin": ALLOWED_ORIGIN}, timeout=30)
    assert response.status_code == 200 and "access-control-allow-origin" not in response.headers
    assert httpx.options(open_recon.url + "/v1/scenes", headers=preflight, timeout=30).status_code == 405


def test_docs_can_be_switched_off(guarded_recon, open_recon):
    for path in ("/docs", "/redoc", "/openapi.json"):
        assert httpx.get(guarded_recon.url + path).status_code == 404
        assert httpx.get(open_recon.url + path).status_code == 200
    assert httpx.get(open_recon.url + "/v1/backbones").status_code == 200  # no keys: no auth


def test_agent_reaches_a_keyed_recon_only_with_its_key(guarded_recon):
    views = orbit_views(seed=5, num_views=3)
    with ReconClient(guarded_recon.url, api_key="alpha-key") as recon:
        scene_id = recon.upload_scene(
            views.pngs(), depths=views.depths, extrinsics=views.extrinsics, intrinsics=views.intrinsics
        ).scene_id
    question, truth = motion_question(views)
    body = {"question": question, "scene_id": scene_id, "backbone": "posed-rgbd"}
    keyed = {
        "PYSPATIAL_RECON_URL": guarded_recon.url,
        "PYSPATIAL_RECON_API_KEY": "agent-to-recon-key",
        "PYSPATIAL_API_KEYS": "agent-key",
    }
    with running_service(AGENT_APP, keyed) as agent:
        assert httpx.post(agent.url + "/v1/solve", json=body, timeout=120).status_code == 401
        solved = httpx.post(agent.url + "/v1/solve", json=body, headers=bearer("agent-key"), timeout=120)
        assert solved.status_code == 200 and solved.json()["answer"] == truth
        assert httpx.get(agent.url + "/readyz").status_code == 200
    with running_service(AGENT_APP, {"PYSPATIAL_RECON_URL": guarded_recon.url}) as keyless_agent:
        refused = httpx.post(keyless_agent.url + "/v1/solve", json=body, timeout=120)
        assert refused.status_code == 502  # our own stack is misconfigured, not the client's fault
        assert "reconstruction service" in refused.json()["detail"]
        assert "API key" in refused.json()["detail"]
        unready = httpx.get(keyless_agent.url + "/readyz", timeout=30)
        assert unready.status_code == 503 and "refuses the agent's key" in unready.json()["reason"]


def test_refused_request_leaves_the_pooled_connection_usable(guarded_recon):
    with httpx.Client(base_url=guarded_recon.url, timeout=30) as client:
        for _ in range(3):  # a 2 MB body refused unread, then the same client again
            refused = client.post(
                "/v1/scenes", content=b"x" * 2_000_000, headers={"content-type": "image/png"}
            )
            assert refused.status_code == 401
            assert client.get("/healthz").status_code == 200


# ---- who the client is, and guessing keys -------------------------------------------------------


NO_SCENE = "/v1/scenes/" + "0" * 24  # a cheap guarded request: 404 once let through


def _limited_recon(tmp_path_factory, **extra: str):
    env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("limited")),
        "PYSPATIAL_RATE_LIMIT_PER_MINUTE": "1",
        "PYSPATIAL_RATE_LIMIT_BURST": "1",
        **extra,
    }
    return running_service(RECON_APP, env)


@pytest.mark.parametrize("proxies", ["10.9.9.9", "127.0.0.1"])
def test_x_forwarded_for_counts_only_from_a_trusted_proxy(tmp_path_factory, proxies):
    """Two "clients" behind one peer: separate limits only when the peer is a trusted proxy."""
    with _limited_recon(tmp_path_factory, PYSPATIAL_TRUSTED_PROXIES=proxies) as recon:
        statuses = [
            httpx.get(recon.url + NO_SCENE, headers={"X-Forwarded-For": client}, timeout=60).status_code
            for client in ("203.0.113.7", "203.0.113.8")
        ]
        spoofed_chain = httpx.get(
            recon.url + NO_SCENE, headers={"X-Forwarded-For": "198.51.100.1, 203.0.113.7"}, timeout=60
        )
    if proxies == "10.9.9.9":  # the test's own address is no proxy: its X-Forwarded-For is ignored
        assert statuses == [404, 429]
    else:  # nginx's: each forwarded client has its own bucket
        assert statuses == [404, 404]
        # the client wrote the left entry itself; the proxy appended the right one, which counts
        assert spoofed_chain.status_code == 429


def test_failed_authentication_is_throttled_per_address(tmp_path_factory):
    env = {"PYSPATIAL_API_KEYS": "the-only-key", "PYSPATIAL_AUTH_FAILURES_PER_MINUTE": "3"}
    with _limited_recon(tmp_path_factory, PYSPATIAL_RATE_LIMIT_PER_MINUTE="0", **env) as recon:
        with httpx.Client(base_url=recon.url, timeout=60) as client:
            guesses = [client.get(NO_SCENE, headers=bearer(f"guess-{n}")) for n in range(5)]
            statuses = [guess.status_code for guess in guesses]
            assert statuses == [401, 401, 401, 429, 429]
            assert int(guesses[-1].headers["retry-after"]) >= 1
            assert "too many failed authentications" in guesses[-1].json()["detail"]
            # another address (through a trusted proxy) is not held back; nor is the right key
            other = client.get(NO_SCENE, headers={**bearer("nope"), "X-Forwarded-For": "203.0.113.9"})
            assert other.status_code == 401
            assert client.get(NO_SCENE, headers=bearer("the-only-key")).status_code == 404
