"""Access control shared by both services: bearer API keys, tenants, per-key rate limits, CORS, /docs.

Tenants: each key belongs to one (`tenant:key` entries in PYSPATIAL_API_KEYS; a plain `key` is the
default tenant's). The tenant of a request is put in `scope["state"]["tenant"]` for the routes. A
service key (`*:key`, the agent's key for recon) acts for the tenant named in `X-PySpatial-Tenant`;
so does every caller when no keys are configured (nothing is authenticated then). A tenant key
always means its own tenant: naming another one in the header is a 403.

Only the API (`/v1/...`) is guarded: `/healthz` and `/readyz` stay open for probes and load
balancers (they carry no data, only whether the service can work), and so do the docs when
they are switched on. The rate limit is a token bucket per key in this process: with N replicas
a key may send up to N times the configured rate (see docs/ARCHITECTURE.md).

The client address is the peer's, unless the peer is one of `PYSPATIAL_TRUSTED_PROXIES`: then it
is the right-most X-Forwarded-For entry that is not a trusted proxy (entries further left were
written by the client and prove nothing). Failed authentications are counted per client
address and answered 429 + Retry-After past `PYSPATIAL_AUTH_FAILURES_PER_MINUTE`, so keys cannot
be guessed at speed.
"""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import json
import math
import re
import threading
import time
from collections import OrderedDict

from fastapi import FastAPI
from starlette.middleware.cors import CORSMiddleware
from starlette.types import ASGIApp, Receive, Scope, Send

from shared.wire.schemas import TENANT_HEADER
from shared.wire.scrubbing import install_log_scrubbing
from shared.wire.settings import AccessSettings

GUARDED_PREFIX = "/v1/"
MAX_TRACKED_CLIENTS = 10_000  # buckets kept in memory; the least recently used are forgotten
DEFAULT_TENANT = "default"
SERVICE_TENANT = "*"  # such a key acts for the tenant its request names (the agent's key for recon)
TENANT_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


def docs_urls(settings: AccessSettings) -> dict:
    """FastAPI(...) keyword arguments that switch /docs, /redoc and /openapi.json on or off."""
    if settings.docs_enabled:
        return {}
    return {"docs_url": None, "redoc_url": None, "openapi_url": None}


def parse_tenant_keys(settings: AccessSettings) -> dict[bytes, str]:
    """key -> tenant. `tenant:key` entries name the tenant (`*` a service key); a plain key (or one
    whose text before the first colon is no tenant name) belongs to the default tenant."""
    raw = settings.api_keys.get_secret_value() if settings.api_keys else ""
    keys: dict[bytes, str] = {}
    for entry in filter(None, (part.strip() for part in raw.split(","))):
        tenant, colon, key = entry.partition(":")
        if colon and key and (tenant == SERVICE_TENANT or TENANT_NAME.match(tenant)):
            keys[key.encode()] = tenant
        else:
            keys[entry.encode()] = DEFAULT_TENANT
    return keys


def parse_keys(settings: AccessSettings) -> list[bytes]:
    return list(parse_tenant_keys(settings))


def request_tenant(scope: Scope) -> str:
    """The tenant AccessMiddleware found for this request (the default one outside /v1/)."""
    return scope.get("state", {}).get("tenant", DEFAULT_TENANT)


def parse_origins(settings: AccessSettings) -> list[str]:
    return [origin.strip() for origin in settings.cors_origins.split(",") if origin.strip()]


class TokenBucket:
    """`rate` tokens per second up to `burst`, one per request, per client identity (thread-safe)."""

    def __init__(self, per_minute: int, burst: int) -> None:
        self.rate = per_minute / 60.0
        self.burst = float(burst)
        self._buckets: OrderedDict[str, tuple[float, float]] = OrderedDict()  # identity -> (tokens, at)
        self._lock = threading.Lock()

    def take(self, identity: str) -> float:
        """0 when the request may go ahead, else the seconds until a token is available."""
        now = time.monotonic()
        with self._lock:
            tokens, at = self._buckets.pop(identity, (self.burst, now))
            tokens = min(self.burst, tokens + (now - at) * self.rate)
            wait = 0.0 if tokens >= 1.0 else (1.0 - tokens) / self.rate
            self._buckets[identity] = (tokens - 1.0 if wait == 0.0 else tokens, now)
            while len(self._buckets) > MAX_TRACKED_CLIENTS:
                self._buckets.popitem(last=False)
        return wait


Network = ipaddress.IPv4Network | ipaddress.IPv6Network


class TrustedProxies:
    """The proxies whose X-Forwarded-For is believed (`*`: any peer), and the client they name."""

    def __init__(self, setting: str) -> None:
        entries = [entry.strip() for entry in setting.split(",") if entry.strip()]
        self.any = "*" in entries
        self.networks: list[Network] = [
            ipaddress.ip_network(entry, strict=False) for entry in entries if entry != "*"
        ]

    def trusts(self, address: str) -> bool:
        if self.any:
            return True
        try:
            ip = ipaddress.ip_address(address)
        except ValueError:
            return False
        return any(ip in network for network in self.networks)

    def client_address(self, scope: Scope) -> str:
        client = scope.get("client")
        peer = client[0] if client else "unknown"
        if not self.trusts(peer):
            return peer  # a client's own X-Forwarded-For is ignored: it would pick its limits
        hops = [hop.strip() for hop in _header(scope, b"x-forwarded-for").split(",") if hop.strip()]
        for hop in reversed(hops):
            if not self.trusts(hop):
                return hop
        return hops[0] if hops else peer


class AccessMiddleware:
    """401 without a valid bearer key (when keys are configured), 429 + Retry-After over the rate
    or after too many failed authentications from one client address."""

    def __init__(
        self,
        app: ASGIApp,
        keys: dict[bytes, str],
        limiter: TokenBucket | None,
        proxies: TrustedProxies,
        auth_failures: TokenBucket | None,
    ) -> None:
        self.app = app
        self.keys = keys
        self.limiter = limiter
        self.proxies = proxies
        self.auth_failures = auth_failures

    def _owner(self, key: bytes) -> str | None:
        """The key's tenant, or None; every known key is compared (no early exit: constant time)."""
        owner = None
        for known, tenant in self.keys.items():
            if hmac.compare_digest(key, known):
                owner = tenant
        return owner

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not scope["path"].startswith(GUARDED_PREFIX):
            await self.app(scope, receive, send)
            return
        address = self.proxies.client_address(scope)
        scope.setdefault("state", {})["client_address"] = address  # for the routes and logs
        identity = f"address:{address}"
        owner = None
        if self.keys:
            key = _bearer_token(scope)
            owner = self._owner(key) if key is not None else None
            if owner is None:
                await self._refuse(send, address, key is None)
                return
            identity = "key:" + hashlib.sha256(key).hexdigest()[:16]  # never keep the key itself
        tenant, refusal = _tenant(scope, owner)
        if tenant is None:
            await _reply(send, 403 if owner not in (None, SERVICE_TENANT) else 400, refusal or "", {})
            return
        scope.setdefault("state", {})["tenant"] = tenant
        if self.limiter is not None:
            wait = self.limiter.take(identity)
            if wait > 0:
                await _too_many(send, wait, "rate limit exceeded")
                return
        await self.app(scope, receive, send)

    async def _refuse(self, send: Send, address: str, missing: bool) -> None:
        """401, or 429 once this address has failed too often (each failure spends a token)."""
        wait = self.auth_failures.take(address) if self.auth_failures is not None else 0.0
        if wait > 0:
            # The challenge says this 429 is about the key, not load: a calling service (the agent)
            # tells its own misconfigured key from being rate-limited.
            await _too_many(send, wait, "too many failed authentications from this address", CHALLENGE)
            return
        reason = "missing bearer API key" if missing else "invalid API key"
        await _reply(send, 401, f"{reason}: send 'Authorization: Bearer <key>'", CHALLENGE)


CHALLENGE = {"www-authenticate": 'Bearer realm="pyspatial"'}


async def _too_many(
    send: Send, wait: float, reason: str, extra_headers: dict[str, str] | None = None
) -> None:
    retry_after = max(1, math.ceil(wait))
    headers = {"retry-after": str(retry_after), **(extra_headers or {})}
    await _reply(send, 429, f"{reason}; retry in {retry_after} s", headers)


def _header(scope: Scope, name: bytes) -> str:
    """All values of one request header, comma-joined (as repeated headers combine)."""
    values = [value.decode("latin-1") for key, value in scope.get("headers", []) if key == name]
    return ",".join(values)


def _tenant(scope: Scope, owner: str | None) -> tuple[str | None, str | None]:
    """(tenant, None), or (None, why not). A tenant key means its own tenant (a header naming
    another is refused, so a misconfigured agent fails loudly instead of mixing tenants); a service
    key, or any caller without keys, means the tenant the header names, else the default."""
    wanted = TENANT_HEADER.lower().encode()
    headers = scope.get("headers", [])
    named = next((value.decode("latin-1") for name, value in headers if name == wanted), None)
    if owner is not None and owner != SERVICE_TENANT:
        if named is not None and named != owner:
            return None, (
                f"this key belongs to tenant {owner!r} and cannot act for {named!r}; a caller that "
                "names tenants (the agent) needs a service key, listed as '*:key'"
            )
        return owner, None
    if named is None:
        return DEFAULT_TENANT, None
    if not TENANT_NAME.match(named):
        return None, f"{TENANT_HEADER} must be a tenant name ({TENANT_NAME.pattern})"
    return named, None


def _bearer_token(scope: Scope) -> bytes | None:
    for name, value in scope.get("headers", []):
        if name == b"authorization":
            scheme, _, token = value.partition(b" ")
            if scheme.lower() == b"bearer" and token.strip():
                return token.strip()
            return None
    return None


async def _reply(send: Send, status: int, detail: str, extra_headers: dict[str, str]) -> None:
    body = json.dumps({"detail": detail}).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    headers += [(name.encode(), value.encode()) for name, value in extra_headers.items()]
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


def install_access_control(app: FastAPI, settings: AccessSettings) -> None:
    """Keys and rate limit on /v1/, and CORS outside them (so preflight requests need no key)."""
    limiter = None
    if settings.rate_limit_per_minute > 0:
        limiter = TokenBucket(settings.rate_limit_per_minute, settings.rate_limit_burst)
    auth_failures = None
    if settings.auth_failures_per_minute > 0:
        per_minute = settings.auth_failures_per_minute
        auth_failures = TokenBucket(per_minute, burst=per_minute)
    keys = parse_tenant_keys(settings)
    install_log_scrubbing([key.decode() for key in keys])  # a key sent in a URL is logged redacted
    app.add_middleware(
        AccessMiddleware,
        keys=keys,
        limiter=limiter,
        proxies=TrustedProxies(settings.trusted_proxies),
        auth_failures=auth_failures,
    )
    origins = parse_origins(settings)
    if origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=origins,
            allow_methods=["GET", "POST"],
            allow_headers=["Authorization", "Content-Type"],
            max_age=600,
        )
