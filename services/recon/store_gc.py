"""Garbage collection of the durable store, so its volume does not fill up.

A scene's age is the mtime of its directory: set when it is stored, refreshed (at most hourly) when
a replica reads it or one of its reconstructions. A pass removes, in this order:
- temporaries under tmp/ older than `STALE_TMP_S` (what a crashed writer left; a live write takes
  seconds),
- scenes unused for longer than `max_age_s` (when set),
- the least recently used scenes while the store is larger than `max_bytes` (when set).
A scene goes with its reconstructions. Removal first renames the scene out of scenes/ (atomic), so a
reader sees it whole or not at all; a replica that still has it in its data dir or memory keeps
serving it until that copy goes too. Every replica may run it at once: a rename lost to another
replica is skipped.
"""

from __future__ import annotations

import logging
import os
import shutil
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from services.recon.durable import DurableStore

log = logging.getLogger("pyspatial.recon.store_gc")

STALE_TMP_S = 3600.0


@dataclass
class GcReport:
    removed: list[str] = field(default_factory=list)  # scene ids, oldest first
    freed_bytes: int = 0
    stale_temporaries: int = 0
    kept_bytes: int = 0


def _size(path: Path) -> int:
    total = 0
    for folder, _, files in os.walk(path):
        for name in files:
            try:
                total += os.lstat(os.path.join(folder, name)).st_size
            except FileNotFoundError:
                pass
    return total


def _entries(store: DurableStore) -> list[tuple[float, str, int]]:
    """(last use, scene id, bytes with its reconstructions) per stored scene, oldest first."""
    entries = []
    for path in store.scenes.iterdir():
        try:
            used = path.stat().st_mtime
        except FileNotFoundError:
            continue
        recon = store.reconstructions / path.name
        with_recon = recon.stat().st_mtime if recon.exists() else used
        entries.append((max(used, with_recon), path.name, _size(path) + _size(recon)))
    return sorted(entries)


def _remove(store: DurableStore, scene_id: str) -> bool:
    """Take the scene out of view with one rename, then delete it and its reconstructions."""
    doomed = store.tmp / f"gc-{scene_id}-{uuid.uuid4().hex[:8]}"
    try:
        os.rename(store.scenes / scene_id, doomed)
    except FileNotFoundError:  # another replica's GC took it
        return False
    shutil.rmtree(doomed, ignore_errors=True)
    shutil.rmtree(store.reconstructions / scene_id, ignore_errors=True)
    return True


def _stale_temporaries(store: DurableStore, now: float) -> int:
    count = 0
    for path in store.tmp.iterdir():
        try:
            if now - path.lstat().st_mtime < STALE_TMP_S:
                continue
        except FileNotFoundError:
            continue
        if path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
        count += 1
    return count


def _orphans(store: DurableStore) -> int:
    """Reconstructions whose scene is gone (written by a replica that still had a local copy)."""
    count = 0
    for path in store.reconstructions.iterdir():
        if not (store.scenes / path.name).exists():
            shutil.rmtree(path, ignore_errors=True)
            count += 1
    return count


def collect(
    store: DurableStore, max_age_s: float = 0.0, max_bytes: int = 0, now: float | None = None
) -> GcReport:
    """One pass over the store; limits of 0 are off. Returns what was removed."""
    now = time.time() if now is None else now
    report = GcReport(stale_temporaries=_stale_temporaries(store, now))
    entries = _entries(store)
    total = sum(size for _, _, size in entries)
    for used, scene_id, size in entries:  # oldest first
        too_old = max_age_s > 0 and now - used > max_age_s
        too_big = max_bytes > 0 and total > max_bytes
        if not (too_old or too_big):
            continue
        if _remove(store, scene_id):
            report.removed.append(scene_id)
            report.freed_bytes += size
        total -= size
    _orphans(store)
    report.kept_bytes = total
    return report


class StoreCollector:
    """Runs `collect` every `interval_s` in a daemon thread until stopped."""

    def __init__(self, store: DurableStore, max_age_s: float, max_bytes: int, interval_s: float) -> None:
        self.store = store
        self.max_age_s = max_age_s
        self.max_bytes = max_bytes
        self.interval_s = interval_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="store-gc", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()

    def _loop(self) -> None:
        while not self._stop.wait(self.interval_s):
            try:
                report = collect(self.store, self.max_age_s, self.max_bytes)
            except OSError as error:  # the volume may be briefly unavailable; try again next time
                log.warning("store GC failed: %s", error)
                continue
            if report.removed or report.stale_temporaries:
                log.info(
                    "store GC: removed %d scenes (%d MiB) and %d stale temporaries; %d MiB kept",
                    len(report.removed),
                    report.freed_bytes // 2**20,
                    report.stale_temporaries,
                    report.kept_bytes // 2**20,
                )
