"""Scenes every replica sees: a copy of each stored scene in Redis, next to the cache.

Each replica keeps its own data dir as a local copy. A scene uploaded to one replica is published
to Redis as one hash (file name -> bytes), written under a temporary key and renamed into place,
so a reader sees the whole scene or none of it. A replica asked for a scene it does not have
fetches that hash and writes it into its data dir the same atomic way as an upload.

Redis is the store the stack already runs; an object store would need a new service in every
deployment for the same guarantee (content-addressed, immutable blobs of bounded size).
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from pathlib import Path

import redis

log = logging.getLogger("pyspatial.recon.scenes")

META = "meta.json"
RETRY_AFTER_FAILURE_S = 2.0


class SharedScenes:
    """Publish and fetch whole scene directories through Redis (sync client; call from threads)."""

    def __init__(self, redis_url: str, namespace: str, ttl_s: int) -> None:
        self._redis = redis.Redis.from_url(redis_url, socket_timeout=10.0, socket_connect_timeout=1.0)
        self.prefix = f"pyspatial:{namespace}:scene:"
        self.ttl_s = ttl_s
        self._pending: dict[str, Path] = {}  # scenes stored locally while Redis was down
        self._lock = threading.Lock()
        self._next_try = 0.0
        self.last_error: str | None = None

    def publish(self, scene_id: str, directory: Path) -> bool:
        """Copy a complete local scene to Redis; False (and retried later) while Redis is down."""
        if time.monotonic() < self._next_try:
            self._remember(scene_id, directory)
            return False
        try:
            self._publish(scene_id, directory)
        except (redis.RedisError, OSError) as error:
            self._failed(error)
            self._remember(scene_id, directory)
            log.warning(
                "scene %s stored locally only (Redis: %s); will publish when it answers", scene_id, error
            )
            return False
        self.last_error = None
        return True

    def _publish(self, scene_id: str, directory: Path) -> None:
        key = self.prefix + scene_id
        if self._redis.exists(key):
            self._redis.expire(key, self.ttl_s)
            return
        staging = f"{key}:incoming:{uuid.uuid4().hex}"
        files = sorted(p for p in directory.iterdir() if p.is_file())
        try:
            for path in files:  # one file per command keeps each command's size bounded
                if path.name != META:
                    self._redis.hset(staging, path.name, path.read_bytes())
            self._redis.hset(staging, META, (directory / META).read_bytes())  # last: marks it complete
            self._redis.expire(staging, self.ttl_s)
            self._redis.rename(staging, key)  # atomic: readers see all of it or nothing
        finally:
            self._redis.delete(staging)

    def fetch(self, scene_id: str, staging: Path) -> bool:
        """Write the scene's files into `staging`; False when Redis does not know the scene."""
        if time.monotonic() < self._next_try:
            return False
        key = self.prefix + scene_id
        try:
            names = [name.decode() for name in self._redis.hkeys(key)]
            if META not in names:
                return False
            for name in names:
                value = self._redis.hget(key, name)
                if value is None:  # expired while we read it
                    return False
                if "/" in name or name.startswith("."):
                    raise ValueError(f"unexpected file name {name!r} in shared scene {scene_id}")
                (staging / name).write_bytes(value)
            self._redis.expire(key, self.ttl_s)
        except (redis.RedisError, OSError) as error:
            if isinstance(error, OSError) and not isinstance(error, ConnectionError):
                raise  # our disk, not Redis: the caller reports it
            self._failed(error)
            return False
        self.last_error = None
        return True

    def catch_up(self) -> int:
        """Publish scenes stored while Redis was down; returns how many are still pending."""
        with self._lock:
            pending = dict(self._pending)
        for scene_id, directory in pending.items():
            if not (directory / META).exists():
                with self._lock:
                    self._pending.pop(scene_id, None)
                continue
            try:
                self._publish(scene_id, directory)
            except (redis.RedisError, OSError) as error:
                self._failed(error)
                break
            with self._lock:
                self._pending.pop(scene_id, None)
        with self._lock:
            return len(self._pending)

    @property
    def pending(self) -> int:
        with self._lock:
            return len(self._pending)

    def _remember(self, scene_id: str, directory: Path) -> None:
        with self._lock:
            self._pending[scene_id] = directory

    def _failed(self, error: Exception) -> None:
        self.last_error = str(error)
        self._next_try = time.monotonic() + RETRY_AFTER_FAILURE_S

    def close(self) -> None:
        self._redis.close()
