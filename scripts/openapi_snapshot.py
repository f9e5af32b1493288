"""Write (or check) the OpenAPI documents of both services, as tests/data/openapi/ keeps them.

    python scripts/openapi_snapshot.py           # rewrite the snapshots after an intended API change
    python scripts/openapi_snapshot.py --check   # exit 1 and print a diff when they differ

The documents are built in-process from each app factory with default settings (no PYSPATIAL_*
variable is read), so they depend on the code alone.
"""

from __future__ import annotations

import argparse
import difflib
import json
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SNAPSHOT_DIR = ROOT / "tests" / "data" / "openapi"
SERVICES = ("recon", "agent")


def current_documents() -> dict[str, str]:
    """Each service's OpenAPI document as canonical JSON text (sorted keys, one-space indent)."""
    for name in [key for key in os.environ if key.startswith("PYSPATIAL_")]:
        del os.environ[name]
    sys.path.insert(0, str(ROOT))
    from services.agent.app import create_app as agent_app
    from services.recon.app import create_app as recon_app

    factories = {"recon": recon_app, "agent": agent_app}
    return {
        name: json.dumps(factories[name]().openapi(), indent=1, sort_keys=True) + "\n" for name in SERVICES
    }


def differences(documents: dict[str, str]) -> str:
    """A unified diff of the stored snapshots against `documents` ('' when they are the same)."""
    lines: list[str] = []
    for name, text in documents.items():
        path = SNAPSHOT_DIR / f"{name}.json"
        stored = path.read_text() if path.exists() else ""
        lines += difflib.unified_diff(
            stored.splitlines(keepends=True), text.splitlines(keepends=True), str(path), f"{name} (code)"
        )
    return "".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    args = parser.parse_args()
    documents = current_documents()
    if args.check:
        diff = differences(documents)
        print(diff or "OpenAPI snapshots are up to date")
        return 1 if diff else 0
    SNAPSHOT_DIR.mkdir(parents=True, exist_ok=True)
    for name, text in documents.items():
        (SNAPSHOT_DIR / f"{name}.json").write_text(text)
        print(f"wrote {SNAPSHOT_DIR / f'{name}.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
