#!/usr/bin/env bash
# Idempotent setup of a fresh clone: system packages, .venv, torch (CPU), then the project.
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON="${PYTHON:-python3}"
log() { printf '[setup] %s\n' "$*"; }

# ---- Python >= 3.11 (starlette-compress, the agent's compression, needs it) ----
if ! command -v "$PYTHON" >/dev/null 2>&1; then
    log "python3 not found: install Python 3.11 or newer"; exit 1
fi
if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
    log "$("$PYTHON" --version 2>&1) is too old: Python 3.11 or newer is required"; exit 1
fi

# ---- system packages (Debian/Ubuntu) ----
# libusb-1.0-0, libgomp1: Open3D; redis-server: the tests' real Redis;
# mesa-vulkan-drivers, libvulkan1, libegl1: Open3D's offscreen renderer (render benchmark).
# chromium, chromium-driver: the web page's browser tests (selenium drives Debian's headless Chromium).
REQUIRED_PACKAGES=(
    libusb-1.0-0 libgomp1 redis-server mesa-vulkan-drivers libvulkan1 libegl1
    chromium chromium-driver
    bubblewrap   # the OS jail of the agent's program sandbox (namespaces, read-only view)
    libseccomp2  # the sandbox worker's seccomp filter (through PyPI pyseccomp)
)
# nginx: the load balancer in front of two recon replicas in tests/test_scale_out.py and bench.load,
# and `nginx -t` of deploy/nginx/nginx.conf (the compose load balancer) in tests/test_compose.py
REQUIRED_PACKAGES+=(nginx)
if command -v dpkg-query >/dev/null 2>&1; then
    missing=()
    for package in "${REQUIRED_PACKAGES[@]}"; do
        status="$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)"
        [[ "$status" == "install ok installed" ]] || missing+=("$package")
    done
    if ((${#missing[@]})); then
        if [[ "$(id -u)" == 0 ]]; then
            log "installing ${missing[*]}"
            apt-get update -qq
            DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
        else
            log "missing system packages; run as root:"
            log "  sudo apt-get install -y ${missing[*]}"
            exit 1
        fi
    fi
else
    command -v redis-server >/dev/null 2>&1 || log "note: not Debian/Ubuntu; install redis-server yourself for the tests"
fi

# ---- virtual environment ----
if [[ ! -x .venv/bin/python ]]; then
    log "creating .venv"
    "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --upgrade pip
# torch first: the pinned CPU build, so the project install does not resolve a CUDA build.
if ! .venv/bin/python -c 'import torch, sys; sys.exit(torch.__version__.split("+")[0] != "2.13.0")' 2>/dev/null; then
    log "installing torch 2.13.0 (CPU)"
    .venv/bin/python -m pip install --quiet torch==2.13.0
fi
log "installing the project (editable, with dev tools)"
.venv/bin/python -m pip install --quiet -e '.[dev]'
log "ready: .venv/bin/pyspatial --help"
