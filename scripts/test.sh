#!/usr/bin/env bash
# Set up, lint, and run the whole test suite (real Redis, real service processes).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/ruff check .
# Two test processes (pytest-xdist), each file on one of them so that a file's module fixtures
# (services, reconstructions) start once: the tests wait on subprocesses and HTTP much of the
# time, so two overlap well even on two cores. PYSPATIAL_TEST_WORKERS=0 runs them in one process.
workers="${PYSPATIAL_TEST_WORKERS:-2}"
status=0
.venv/bin/pytest -q -n "$workers" --dist loadfile "$@" || status=$?
if [[ $status == 5 ]]; then
    echo "pytest collected no tests: treating that as a failure" >&2
    exit 1
fi
exit "$status"
