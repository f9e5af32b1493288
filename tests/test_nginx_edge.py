"""nginx's edge limits: the deployment's config and the local balancer agree, and a slow client
(slowloris) against the real nginx is cut off there without holding a service worker."""

from __future__ import annotations

import re
import socket
import time

import httpx
import pytest

from shared.local.nginx import CONFIG, PER_CLIENT_LIMITS, running_nginx
from tests.support.misbehaving import MisbehavingServer, forward
from tests.support.processes import REPO_ROOT, running_service

EDGE_DIRECTIVES = (
    "client_header_timeout",
    "client_body_timeout",
    "send_timeout",
    "keepalive_timeout",
    "limit_conn_zone",
    "limit_req_zone",
    "limit_conn",
    "limit_req",
    "limit_conn_status",
    "limit_req_status",
)


def directives(text: str) -> dict[str, str]:
    found = {}
    for name in EDGE_DIRECTIVES:
        match = re.search(rf"^\s*{name}\s+([^;]+);", text, re.MULTILINE)
        assert match, f"{name} is missing"
        found[name] = match.group(1).strip()
    return found


def test_the_local_balancer_has_the_deployments_edge_limits():
    deployed = directives((REPO_ROOT / "deploy" / "nginx" / "nginx.conf").read_text())
    local = CONFIG.format(
        prefix="/p",
        servers="",
        port=1,
        header_timeout="10s",
        body_timeout="30s",
        per_client_limits=PER_CLIENT_LIMITS,
    )
    assert directives(local) == deployed
    assert deployed["client_header_timeout"] == "10s" and deployed["limit_req_status"] == "429"


@pytest.fixture(scope="module")
def recon(tmp_path_factory):
    with running_service(
        "services.recon.app:create_app", {"PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("r"))}
    ) as service:
        yield service


def _closed_within(connection: socket.socket, seconds: float) -> bool:
    """True when the peer closes (or answers and closes) before `seconds` pass."""
    connection.settimeout(seconds)
    try:
        while connection.recv(4096):
            pass
        return True
    except TimeoutError:
        return False
    except OSError:
        return True


def test_a_slow_client_is_cut_off_by_nginx_without_holding_the_upstream(recon):
    port = int(recon.url.rsplit(":", 1)[1])
    with (
        MisbehavingServer(lambda connection, _: forward(connection, port)) as upstream,
        running_nginx(
            [upstream.url], header_timeout="2s", body_timeout="2s", per_client_limits=True
        ) as nginx,
    ):
        host, nginx_port = "127.0.0.1", int(nginx.url.rsplit(":", 1)[1])
        slow_heads = []
        for _ in range(20):  # request heads that never end: the slowloris attack
            connection = socket.create_connection((host, nginx_port))
            connection.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\nX-Slow: 1\r\n")
            slow_heads.append(connection)
        slow_body = socket.create_connection((host, nginx_port))  # a body that stalls
        slow_body.sendall(
            b"POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Length: 100000\r\n\r\n" + b"x" * 10
        )
        started = time.monotonic()
        assert httpx.get(nginx.url + "/healthz", timeout=10).status_code == 200  # others are served
        held = upstream.connections
        assert held <= 2, held  # nginx opened upstream connections for the served requests only
        assert all(_closed_within(connection, 8) for connection in slow_heads)
        assert _closed_within(slow_body, 8)
        assert time.monotonic() - started < 10
        for connection in (*slow_heads, slow_body):
            connection.close()
        assert httpx.get(nginx.url + "/healthz", timeout=10).status_code == 200
