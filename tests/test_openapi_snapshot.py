"""The OpenAPI documents of both services equal the committed snapshots.

A refactor must leave both HTTP APIs as they were; an intended API change updates the snapshot
in the same commit (`python scripts/openapi_snapshot.py`), so the diff shows the change.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_openapi_documents_match_the_snapshots() -> None:
    # A fresh interpreter: no PYSPATIAL_* variable and no app state of other tests leaks in.
    result = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "openapi_snapshot.py"), "--check"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, (
        "the OpenAPI of a service changed; if that is intended, run "
        "`python scripts/openapi_snapshot.py` and commit the snapshot:\n"
        + result.stdout[-6000:]
        + result.stderr
    )
