"""Serialized reconstructions: an in-process LRU in front of Redis, in front of the durable store.

Redis may be absent (no REDIS_URL), go down, or forget keys (eviction, restart). The service then
keeps answering from memory, and from the durable store (PYSPATIAL_STORE_DIR) when it has one,
remembers what it could not write to Redis, and writes it back once Redis answers ("catch up").
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from collections import OrderedDict

import anyio
import redis
from redis import asyncio as aioredis

from services.recon.durable import DurableStore

log = logging.getLogger("pyspatial.recon.cache")

RETRY_AFTER_FAILURE_S = 2.0  # don't hammer a dead Redis on every request
LOCAL_LEASE = "local"  # granted without Redis: nobody else to coordinate with
_RELEASE_IF_OWNER = (
    "if redis.call('get', KEYS[1]) == ARGV[1] then return redis.call('del', KEYS[1]) end return 0"
)
_RENEW_IF_OWNER = (
    "if redis.call('get', KEYS[1]) == ARGV[1] then return redis.call('expire', KEYS[1], ARGV[2]) end return 0"
)


class MemoryLRU:
    """Byte-bounded LRU of bytes values; thread-safe."""

    def __init__(self, max_bytes: int) -> None:
        self.max_bytes = max_bytes
        self._items: OrderedDict[str, bytes] = OrderedDict()
        self._size = 0
        self._lock = threading.Lock()

    def get(self, key: str) -> bytes | None:
        with self._lock:
            value = self._items.get(key)
            if value is not None:
                self._items.move_to_end(key)
            return value

    def set(self, key: str, value: bytes) -> None:
        with self._lock:
            if key in self._items:
                self._size -= len(self._items.pop(key))
            if len(value) > self.max_bytes:
                return
            self._items[key] = value
            self._size += len(value)
            while self._size > self.max_bytes:
                _, evicted = self._items.popitem(last=False)
                self._size -= len(evicted)

    def __contains__(self, key: str) -> bool:
        with self._lock:
            return key in self._items


class ReconstructionCache:
    def __init__(
        self,
        redis_url: str | None,
        ttl_s: int,
        memory_bytes: int,
        namespace: str = "default",
        durable: DurableStore | None = None,
    ) -> None:
        self.redis_url = redis_url
        self.durable = durable
        self.key_prefix = f"pyspatial:{namespace}:recon:"
        self.ttl_s = ttl_s
        self.memory = MemoryLRU(memory_bytes)
        self._redis = (
            aioredis.Redis.from_url(redis_url, socket_timeout=2.0, socket_connect_timeout=1.0)
            if redis_url
            else None
        )
        self._down_since: float | None = None
        self._next_try = 0.0
        self._pending: set[str] = set()  # written to memory while Redis was down

    @property
    def mode(self) -> str:
        if self._redis is None:
            return "memory"
        return "redis-unavailable" if self._down_since is not None else "redis"

    def _available(self) -> bool:
        return self._redis is not None and time.monotonic() >= self._next_try

    def _failed(self, error: Exception) -> None:
        if self._down_since is None:
            log.warning("Redis unavailable (%s); serving from the in-process cache", error)
            self._down_since = time.monotonic()
        self._next_try = time.monotonic() + RETRY_AFTER_FAILURE_S

    async def _recovered(self) -> None:
        if self._down_since is not None:
            log.warning(
                "Redis is back after %.1f s; writing back %d entries",
                time.monotonic() - self._down_since,
                len(self._pending),
            )
            self._down_since = None
        for key in list(self._pending):
            value = self.memory.get(key)
            if value is not None:
                await self._redis.set(self.key_prefix + key, value, ex=self.ttl_s)
            self._pending.discard(key)

    async def get(self, key: str) -> bytes | None:
        value = self.memory.get(key)
        if value is not None:
            return value
        value = await self._redis_get(key)
        if value is None and self.durable is not None:
            value = await self._durable_get(key)
        if value is not None:
            self.memory.set(key, value)
        return value

    async def _redis_get(self, key: str) -> bytes | None:
        if not self._available():
            return None
        try:
            value = await self._redis.get(self.key_prefix + key)
            await self._recovered()
        except (redis.RedisError, OSError) as error:
            self._failed(error)
            return None
        return value

    async def _durable_get(self, key: str) -> bytes | None:
        try:
            return await anyio.to_thread.run_sync(self.durable.get_blob, key)
        except OSError as error:  # the store of record unreadable: recompute rather than fail
            log.warning("durable store: cannot read %s (%s)", key, error)
            return None

    async def set(self, key: str, value: bytes) -> None:
        self.memory.set(key, value)
        if self.durable is not None:
            try:
                await anyio.to_thread.run_sync(self.durable.put_blob, key, value)
            except OSError as error:  # the result is still served; a later request recomputes it
                log.warning("durable store: cannot write %s (%s)", key, error)
        if self._redis is None:
            return
        if not self._available():
            self._pending.add(key)
            return
        try:
            await self._redis.set(self.key_prefix + key, value, ex=self.ttl_s)
            await self._recovered()
        except (redis.RedisError, OSError) as error:
            self._pending.add(key)
            self._failed(error)

    # ---- leases: one reconstruction per key across every replica sharing this Redis ----------

    async def acquire_lease(self, key: str, ttl_s: int) -> str | None:
        """A token when this process may compute `key`; None when another replica holds the lease.

        Without Redis (or while it is down) there is nobody to coordinate with: the lease is
        granted locally (token LOCAL_LEASE). The TTL bounds how long a crashed holder blocks others.
        """
        if not self._available():
            return LOCAL_LEASE
        token = uuid.uuid4().hex
        try:
            acquired = await self._redis.set(self.key_prefix + "lease:" + key, token, nx=True, ex=ttl_s)
        except (redis.RedisError, OSError) as error:
            self._failed(error)
            return LOCAL_LEASE
        return token if acquired else None

    async def renew_lease(self, key: str, token: str, ttl_s: int) -> bool:
        """Extend our lease (the heartbeat); False when it is no longer ours (expired, taken over)."""
        if token == LOCAL_LEASE or not self._available():
            return True
        try:
            renewed = await self._redis.eval(
                _RENEW_IF_OWNER, 1, self.key_prefix + "lease:" + key, token, ttl_s
            )
        except (redis.RedisError, OSError) as error:
            self._failed(error)
            return True  # Redis down: nobody can take it over through Redis either
        return bool(renewed)

    async def lease_held(self, key: str) -> bool:
        """Whether some replica holds the lease on `key` now (False without Redis)."""
        if not self._available():
            return False
        try:
            return bool(await self._redis.exists(self.key_prefix + "lease:" + key))
        except (redis.RedisError, OSError) as error:
            self._failed(error)
            return False

    async def release_lease(self, key: str, token: str) -> None:
        if token == LOCAL_LEASE or not self._available():
            return
        try:  # delete only our own lease: it may have expired and been taken by another replica
            await self._redis.eval(_RELEASE_IF_OWNER, 1, self.key_prefix + "lease:" + key, token)
        except (redis.RedisError, OSError) as error:
            self._failed(error)

    async def check(self) -> str:
        """Ping Redis (used by /readyz), catching up if it has come back. Returns the mode."""
        if self._redis is None:
            return self.mode
        try:
            await self._redis.ping()
            await self._recovered()
        except (redis.RedisError, OSError) as error:
            self._failed(error)
        return self.mode

    @property
    def pending_writes(self) -> int:
        return len(self._pending)

    async def close(self) -> None:
        if self._redis is not None:
            await self._redis.aclose()
