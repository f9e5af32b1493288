#!/usr/bin/env bash
# Set up, lint, and run the whole test suite (real Redis, real service processes).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/ruff check .
status=0
.venv/bin/pytest -q "$@" || status=$?
if [[ $status == 5 ]]; then
    echo "pytest collected no tests: treating that as a failure" >&2
    exit 1
fi
exit "$status"
