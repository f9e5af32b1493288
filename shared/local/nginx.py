"""A real nginx as a round-robin load balancer in front of local replicas (tests and benches).

Runs Debian's `nginx` binary as a foreground child process with its own prefix directory and a
config written here, on a free port; it never touches the system nginx service.
"""

from __future__ import annotations

import contextlib
import shutil
import subprocess
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import httpx

from shared.local.services import free_port

# Per client address; off by default here: a bench's load comes from one address.
PER_CLIENT_LIMITS = """    limit_conn_zone $binary_remote_addr zone=per_client:10m;
    limit_req_zone $binary_remote_addr zone=per_client_rate:10m rate=20r/s;
    limit_conn per_client 32;
    limit_req zone=per_client_rate burst=40 nodelay;
    limit_conn_status 429;
    limit_req_status 429;
"""

CONFIG = """worker_processes 1;
pid {prefix}/nginx.pid;
error_log {prefix}/error.log warn;
events {{ worker_connections 1024; }}
http {{
    access_log off;
    client_body_temp_path {prefix}/client_body;
    proxy_temp_path {prefix}/proxy;
    fastcgi_temp_path {prefix}/fastcgi;
    uwsgi_temp_path {prefix}/uwsgi;
    scgi_temp_path {prefix}/scgi;
    client_max_body_size 0;  # the services enforce their own limits
    # the edge limits of deploy/nginx/nginx.conf (tests/test_nginx_edge.py checks they agree)
    client_header_timeout {header_timeout};
    client_body_timeout {body_timeout};
    send_timeout 60s;
    keepalive_timeout 65s;
{per_client_limits}    upstream replicas {{
{servers}
        keepalive 32;
    }}
    server {{
        listen 127.0.0.1:{port};
        location / {{
            proxy_pass http://replicas;
            proxy_http_version 1.1;
            proxy_set_header Connection "";
            proxy_request_buffering off;
            proxy_read_timeout 900s;
            proxy_next_upstream error timeout;
        }}
    }}
}}
"""


@dataclass
class Nginx:
    url: str
    process: subprocess.Popen
    prefix: Path

    def error_log(self) -> str:
        path = self.prefix / "error.log"
        return path.read_text(errors="replace") if path.exists() else ""

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=5)
        shutil.rmtree(self.prefix, ignore_errors=True)


def start_nginx(
    upstreams: Sequence[str],
    header_timeout: str = "10s",
    body_timeout: str = "30s",
    per_client_limits: bool = False,
) -> Nginx:
    """nginx on a free port balancing round-robin over `upstreams` ("http://host:port"), with the
    deployment's edge timeouts (shorter when a test wants to watch them act) and, when asked, its
    per-client connection and request limits."""
    binary = shutil.which("nginx") or "/usr/sbin/nginx"
    if not Path(binary).exists():
        raise RuntimeError("nginx is not installed: run scripts/setup.sh (apt-get install nginx)")
    prefix = Path(tempfile.mkdtemp(prefix="pyspatial-nginx-"))
    port = free_port()
    servers = "\n".join(f"        server {url.removeprefix('http://')};" for url in upstreams)
    config = CONFIG.format(
        prefix=prefix,
        servers=servers,
        port=port,
        header_timeout=header_timeout,
        body_timeout=body_timeout,
        per_client_limits=PER_CLIENT_LIMITS if per_client_limits else "",
    )
    (prefix / "nginx.conf").write_text(config)
    process = subprocess.Popen(
        [binary, "-p", str(prefix), "-c", str(prefix / "nginx.conf"), "-g", "daemon off;"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.STDOUT,
    )
    balancer = Nginx(url=f"http://127.0.0.1:{port}", process=process, prefix=prefix)
    deadline = time.monotonic() + 10
    while True:
        if process.poll() is not None:
            log = balancer.error_log()
            balancer.stop()
            raise RuntimeError(f"nginx exited with {process.returncode}: {log}")
        with contextlib.suppress(httpx.HTTPError):
            httpx.get(balancer.url + "/healthz", timeout=1.0)
            return balancer
        if time.monotonic() > deadline:
            balancer.stop()
            raise RuntimeError("nginx did not start listening in 10 s")
        time.sleep(0.05)


@contextlib.contextmanager
def running_nginx(upstreams: Sequence[str], **options) -> Iterator[Nginx]:
    balancer = start_nginx(upstreams, **options)
    try:
        yield balancer
    finally:
        balancer.stop()
