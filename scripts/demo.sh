#!/usr/bin/env bash
# Set up, then run the bundled example through both services on this machine.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec .venv/bin/pyspatial demo "$@"
