#!/usr/bin/env bash
# Refresh the vendored JavaScript from the npm registry at pinned versions:
# - the web page's libraries (three.js, MIT; highlight.js, BSD-3-Clause) into services/agent/web/vendor/;
# - axe-core (MPL-2.0), which only the browser tests load, into tests/support/vendor/.
# The files are committed with their licences and SHA256SUMS, so nothing is fetched at setup, test or
# run time; this script is how they got there, and how to upgrade. Each library lives in a folder
# named with its version: the page serves those URLs with a one-year immutable cache lifetime, so a
# new version must get a new URL (and the page's import map and tags follow from the folder names).
set -euo pipefail
cd "$(dirname "$0")/.."
THREE_VERSION=0.187.0
HIGHLIGHT_VERSION=11.11.1
AXE_VERSION=4.14.1
vendor=services/agent/web/vendor
test_vendor=tests/support/vendor
three="$vendor/three-$THREE_VERSION"
highlight="$vendor/highlight-$HIGHLIGHT_VERSION"
axe="$test_vendor/axe-core-$AXE_VERSION"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
(cd "$work" && npm pack --silent "three@$THREE_VERSION" "@highlightjs/cdn-assets@$HIGHLIGHT_VERSION" \
    "axe-core@$AXE_VERSION" >/dev/null)
mkdir -p "$work/three" "$work/highlight" "$work/axe" "$three" "$highlight" "$axe"
tar xzf "$work/three-$THREE_VERSION.tgz" -C "$work/three"
tar xzf "$work/highlightjs-cdn-assets-$HIGHLIGHT_VERSION.tgz" -C "$work/highlight"
tar xzf "$work/axe-core-$AXE_VERSION.tgz" -C "$work/axe"
cp "$work/three/package/build/three.module.js" "$work/three/package/build/three.core.js" \
    "$work/three/package/examples/jsm/controls/OrbitControls.js" "$work/three/package/LICENSE" "$three/"
cp "$work/highlight/package/highlight.min.js" "$work/highlight/package/styles/github.min.css" \
    "$work/highlight/package/LICENSE" "$highlight/"
cp "$work/axe/package/axe.min.js" "$work/axe/package/LICENSE" "$work/axe/package/LICENSE-3RD-PARTY.txt" "$axe/"
(cd "$vendor" && sha256sum "three-$THREE_VERSION"/* "highlight-$HIGHLIGHT_VERSION"/* > SHA256SUMS)
(cd "$test_vendor" && sha256sum "axe-core-$AXE_VERSION"/* > SHA256SUMS)
echo "vendored three@$THREE_VERSION, @highlightjs/cdn-assets@$HIGHLIGHT_VERSION and axe-core@$AXE_VERSION"
