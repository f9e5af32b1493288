"""Reconstruction jobs: one per key in this process, one per key across replicas, bounded queues.

- Single flight in a process: requests for the same key await one job; the job belongs to no
  request, so a client leaving does not fail the others. When every waiting client has gone and the
  job has not started, it is cancelled (an abandoned request never holds a place in the queue).
- Across replicas: the job takes the Redis lease only when it is about to compute (after it got a
  worker slot), renews it with a heartbeat while the work runs and releases it when done or failed.
  A crashed holder stops renewing, so its lease expires after at most `reconstruct_lease_s`.
  Waiters poll the cache; after `reconstruct_wait_s` they give up with a 503.
- Admission: at most `max_queued_reconstructions` jobs wait for a worker slot; beyond that a 503
  with Retry-After.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from services.recon.cache import ReconstructionCache
from services.recon.errors import LeaseWaitTimeout, Overloaded

log = logging.getLogger("pyspatial.recon.jobs")

T = TypeVar("T")
POLL_S = 0.25  # how often a waiter looks for another replica's result


@dataclass
class JobResult(Generic[T]):
    value: T
    computed_here: bool  # False: another replica computed it (read from the shared cache)


@dataclass
class _Job:
    task: asyncio.Task | None = None
    waiters: int = 0
    running: bool = False  # the backbone has started: let it finish (its result is cached)
    queued_at: float = field(default_factory=time.monotonic)


class ReconstructionJobs:
    def __init__(
        self,
        cache: ReconstructionCache,
        workers: int,
        max_queued: int,
        lease_s: int,
        wait_s: float,
    ) -> None:
        self.cache = cache
        self.workers = workers
        self.max_queued = max_queued
        self.lease_s = lease_s
        self.wait_s = wait_s
        self._slots = asyncio.Semaphore(workers)
        self._jobs: dict[str, _Job] = {}
        self._held: dict[str, str] = {}  # key -> token of each lease this replica holds now
        self.draining = False

    @property
    def queued(self) -> int:
        return sum(1 for job in self._jobs.values() if not job.running)

    @property
    def running(self) -> int:
        return sum(1 for job in self._jobs.values() if job.running)

    async def run(
        self,
        key: str,
        compute: Callable[[], Awaitable[T]],
        load: Callable[[bytes], Awaitable[T]],
    ) -> tuple[JobResult[T], bool]:
        """The job's result and whether this caller joined a job already under way."""
        job = self._jobs.get(key)
        joined = job is not None
        if job is None:
            if self.draining:
                raise Overloaded("the service is shutting down; retry on another replica", retry_after_s=1)
            if self.queued >= self.max_queued:
                raise Overloaded(
                    f"{self.queued} reconstructions are queued already (limit {self.max_queued}); retry",
                    retry_after_s=max(1, int(self.lease_s // 3)),
                )
            job = _Job()
            job.task = asyncio.create_task(self._drive(key, job, compute, load), name=f"reconstruct {key}")
            self._jobs[key] = job
        job.waiters += 1
        try:
            return await asyncio.shield(job.task), joined
        finally:
            job.waiters -= 1
            if job.waiters == 0 and not job.running and not job.task.done():
                log.info("cancelling queued reconstruction %s: every client has gone", key)
                if self._jobs.get(key) is job:  # a new request for the key starts a new job
                    del self._jobs[key]
                job.task.cancel()

    async def _drive(
        self, key: str, job: _Job, compute: Callable[[], Awaitable[T]], load: Callable[[bytes], Awaitable[T]]
    ) -> JobResult[T]:
        deadline = time.monotonic() + self.wait_s
        try:
            while True:
                payload = await self.cache.get(key)
                if payload is not None:
                    return JobResult(await load(payload), computed_here=False)
                if not await self.cache.lease_held(key):
                    result = await self._compute_with_lease(key, job, compute, deadline)
                    if result is not None:
                        return result
                if time.monotonic() > deadline:
                    raise LeaseWaitTimeout(
                        f"waited {self.wait_s:.0f} s for another replica's reconstruction of this scene "
                        "(it still holds the lease); retry later",
                        retry_after_s=max(1, int(self.lease_s)),
                    )
                await asyncio.sleep(POLL_S)
        finally:
            if self._jobs.get(key) is job:
                del self._jobs[key]

    async def _compute_with_lease(
        self, key: str, job: _Job, compute: Callable[[], Awaitable[T]], deadline: float
    ) -> JobResult[T] | None:
        """Compute under the lease once a worker slot is free; None when another replica won it."""
        try:
            await asyncio.wait_for(self._slots.acquire(), timeout=max(0.01, deadline - time.monotonic()))
        except TimeoutError:
            raise LeaseWaitTimeout(
                f"no reconstruction worker became free within {self.wait_s:.0f} s; retry later",
                retry_after_s=max(1, int(self.lease_s)),
            ) from None
        try:
            payload = await self.cache.get(key)  # finished elsewhere while we queued
            if payload is not None:
                return None
            token = await self.cache.acquire_lease(key, self.lease_s)
            if token is None:
                return None
            job.running = True
            self._held[key] = token
            heartbeat = asyncio.create_task(self._heartbeat(key, token))
            try:
                return JobResult(await compute(), computed_here=True)
            finally:
                heartbeat.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await heartbeat
                await asyncio.shield(self._release(key, token))
        finally:
            self._slots.release()

    async def _release(self, key: str, token: str) -> None:
        if self._held.get(key) == token:
            del self._held[key]
            await self.cache.release_lease(key, token)

    async def _heartbeat(self, key: str, token: str) -> None:
        interval = max(0.5, self.lease_s / 3)
        while True:
            await asyncio.sleep(interval)
            if not await self.cache.renew_lease(key, token, self.lease_s):
                log.warning("lost the reconstruction lease on %s (expired or taken over)", key)
                return

    async def drain(self, timeout_s: float) -> None:
        """On shutdown: refuse new jobs, drop queued ones, give running ones `timeout_s`, then stop."""
        self.draining = True
        for job in list(self._jobs.values()):
            if not job.running and job.task is not None:
                job.task.cancel()
        tasks = [job.task for job in self._jobs.values() if job.task is not None]
        if tasks:
            _, pending = await asyncio.wait(tasks, timeout=timeout_s)
            for task in pending:  # releases their leases (finally) so another replica takes over
                task.cancel()
            if pending:
                await asyncio.wait(pending, timeout=2.0)
        # A loaded machine may not have run every cancelled job's `finally` yet: release what is
        # still held here, before the cache connection closes, so no other replica waits on it.
        for key, token in list(self._held.items()):
            await self._release(key, token)
