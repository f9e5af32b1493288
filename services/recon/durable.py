"""The store of record: scenes and reconstructions on a volume every replica mounts.

Redis is a cache (it may forget any key at any moment: a restart, an eviction); this directory is
what a scene is lost with. Layout, content-addressed by scene id (itself derived from the content):

    <store>/scenes/<scene_id>/                 the uploaded files and meta.json, never changed
    <store>/reconstructions/<scene_id>/<hash>  one serialized reconstruction per cache key
    <store>/tmp/                               what is being written (and what a crash left)

Every write goes to a temporary name under tmp/ on the same file system, is fsynced, and is
renamed into place; the parent directory is fsynced after the rename. A reader therefore sees a
whole scene or none, even across a crash of the writer or of the machine. Entries are immutable,
so two replicas writing the same scene race harmlessly: the first rename wins, the second finds
the target there and drops its copy. Old temporaries are removed by `services/recon/store_gc.py`.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import time
from pathlib import Path

META = "meta.json"
TOUCH_EVERY_S = 3600.0  # a read refreshes the entry's age for the GC at most this often


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _write_synced(path: Path, data: bytes) -> None:
    with open(path, "wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())


def _touch(path: Path) -> None:
    """Mark an entry as used (its mtime is its age for the GC), rarely: the volume may be remote."""
    try:
        if time.time() - path.stat().st_mtime > TOUCH_EVERY_S:
            os.utime(path)
    except OSError:
        pass  # removed meanwhile, or a read-only mount: the age only matters to the GC


class DurableStore:
    """Atomic, fsynced, content-addressed files; safe for many processes on many machines."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        self.scenes = self.root / "scenes"
        self.reconstructions = self.root / "reconstructions"
        self.tmp = self.root / "tmp"
        for folder in (self.scenes, self.reconstructions, self.tmp):
            folder.mkdir(parents=True, exist_ok=True)

    # ---- scenes -------------------------------------------------------------------------------

    def has_scene(self, scene_id: str) -> bool:
        return (self.scenes / scene_id / META).exists()

    def put_scene(self, scene_id: str, directory: Path) -> bool:
        """Copy a complete local scene directory in; False when the store had it already."""
        final = self.scenes / scene_id
        if (final / META).exists():
            _touch(final)
            return False
        staging = Path(tempfile.mkdtemp(prefix=f"scene-{scene_id}-", dir=self.tmp))
        try:
            names = sorted(p.name for p in directory.iterdir() if p.is_file() and p.name != META)
            for name in [*names, META]:  # meta.json last: a complete scene has it
                _write_synced(staging / name, (directory / name).read_bytes())
            _fsync_dir(staging)
            try:
                os.rename(staging, final)
            except OSError:  # another replica stored it first (rename onto a non-empty dir fails)
                if not (final / META).exists():
                    raise
                return False
            _fsync_dir(self.scenes)
            return True
        finally:
            if staging.exists():
                shutil.rmtree(staging, ignore_errors=True)

    def get_scene(self, scene_id: str, staging: Path) -> bool:
        """Copy the scene's files into `staging`; False when the store does not have it."""
        source = self.scenes / scene_id
        if not (source / META).exists():
            return False
        try:
            for path in source.iterdir():
                if path.is_file():
                    shutil.copyfile(path, staging / path.name)
        except FileNotFoundError:  # collected by the GC while we copied
            return False
        _touch(source)
        return True

    # ---- reconstructions ----------------------------------------------------------------------

    def _blob_path(self, key: str) -> Path:
        scene_id = key.split(":", 1)[0]
        return self.reconstructions / scene_id / hashlib.sha256(key.encode()).hexdigest()[:32]

    def get_blob(self, key: str) -> bytes | None:
        path = self._blob_path(key)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            return None
        _touch(path.parent)
        return data

    def put_blob(self, key: str, data: bytes) -> None:
        final = self._blob_path(key)
        if final.exists():
            return
        final.parent.mkdir(parents=True, exist_ok=True)
        handle, name = tempfile.mkstemp(prefix="blob-", dir=self.tmp)
        os.close(handle)
        temporary = Path(name)
        try:
            _write_synced(temporary, data)
            os.replace(temporary, final)  # same content under the same key: replacing is harmless
            _fsync_dir(final.parent)
        finally:
            temporary.unlink(missing_ok=True)
