"""Scene ids per tenant: the same upload is one scene within a tenant and unguessable outside it.

The default tenant (plain keys, or no keys) keeps the bare content hash as its scene id, so scenes
stored before tenants existed keep their ids. Another tenant's id is HMAC-SHA256 of the content hash
under that tenant's secret, itself HMAC(scene id secret, tenant name): stable across key rotation
(it depends on the tenant's name, not on its keys), and nobody without the secret can compute an id
from content they hold. Reading is guarded as well: every stored scene records its tenant and is
served to that tenant only (`SceneStore.info`), so an id that leaked is still a 404 elsewhere.

The scene id secret is PYSPATIAL_SCENE_ID_SECRET when set; otherwise a random one is created once in
the store of record (or the data dir without one), where every replica finds the same.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
from pathlib import Path

from shared.wire.access import DEFAULT_TENANT

SECRET_FILE = "scene-id-secret"


def load_or_create_secret(folder: Path) -> bytes:
    """The secret in `folder`, created atomically by the first replica to need it."""
    path = Path(folder) / SECRET_FILE
    try:
        return bytes.fromhex(path.read_text().strip())
    except FileNotFoundError:
        pass
    folder.mkdir(parents=True, exist_ok=True)
    candidate = path.with_name(f".{SECRET_FILE}-{os.getpid()}-{secrets.token_hex(4)}")
    with open(candidate, "w") as handle:
        handle.write(secrets.token_hex(32))
        handle.flush()
        os.fsync(handle.fileno())
    try:
        os.link(candidate, path)  # fails when another replica created it first: theirs wins
    except FileExistsError:
        pass
    finally:
        candidate.unlink(missing_ok=True)
    return bytes.fromhex(path.read_text().strip())


class SceneIds:
    def __init__(self, secret: bytes) -> None:
        self._secret = secret

    def scene_id(self, tenant: str, content_id: str) -> str:
        """The id a tenant's upload with this content hash gets (24 hex characters)."""
        if tenant == DEFAULT_TENANT:
            return content_id
        tenant_secret = hmac.new(self._secret, b"tenant:" + tenant.encode(), hashlib.sha256).digest()
        return hmac.new(tenant_secret, content_id.encode(), hashlib.sha256).hexdigest()[:24]
