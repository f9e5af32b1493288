#!/usr/bin/env bash
# Refresh the web page's vendored libraries from the npm registry at pinned versions.
# The files are committed (MIT: three.js; BSD-3-Clause: highlight.js; licences alongside), so
# nothing is fetched at setup or run time; this script is how they got there, and how to upgrade.
set -euo pipefail
cd "$(dirname "$0")/.."
THREE_VERSION=0.187.0
HIGHLIGHT_VERSION=11.11.1
vendor=services/agent/web/vendor
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
(cd "$work" && npm pack --silent "three@$THREE_VERSION" "@highlightjs/cdn-assets@$HIGHLIGHT_VERSION" >/dev/null)
mkdir -p "$work/three" "$work/highlight" "$vendor/three" "$vendor/highlight"
tar xzf "$work/three-$THREE_VERSION.tgz" -C "$work/three"
tar xzf "$work/highlightjs-cdn-assets-$HIGHLIGHT_VERSION.tgz" -C "$work/highlight"
cp "$work/three/package/build/three.module.js" "$work/three/package/build/three.core.js" \
    "$work/three/package/examples/jsm/controls/OrbitControls.js" "$work/three/package/LICENSE" "$vendor/three/"
cp "$work/highlight/package/highlight.min.js" "$work/highlight/package/styles/github.min.css" \
    "$work/highlight/package/LICENSE" "$vendor/highlight/"
(cd "$vendor" && sha256sum three/* highlight/* > SHA256SUMS)
echo "vendored three@$THREE_VERSION and @highlightjs/cdn-assets@$HIGHLIGHT_VERSION into $vendor"
