#!/usr/bin/env bash
# Serves an export folder on loopback and screenshots its three.js viewer with headless Chromium
# (SwiftShader WebGL, no GPU needed). Prints the page title (says "rendered" or the error).
# Usage: web/screenshot.sh EXPORT_DIR 'QUERY' OUT.png W H
set -euo pipefail
dir=$1 query=$2 out=$3 w=$4 h=$5
source "$(dirname "$0")/serve.sh"
server=
trap 'kill $server 2>/dev/null || true' EXIT
serve "$dir" export.json
profile=$(mktemp -d)
url="http://127.0.0.1:$port/three/viewer.html?$query"
# Each Chromium run is bounded (a hung browser fails the caller instead of stalling it).
timeout 180 chromium --headless=new --no-sandbox --disable-gpu-sandbox --use-angle=swiftshader \
  --enable-unsafe-swiftshader --user-data-dir="$profile" --hide-scrollbars \
  --window-size="$w,$h" --virtual-time-budget=20000 --screenshot="$out" "$url" 2>/dev/null >/dev/null || true
timeout 180 chromium --headless=new --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader \
  --user-data-dir="$profile" --virtual-time-budget=20000 --dump-dom "$url" 2>/dev/null |
  grep -o '<title>[^<]*</title>' || echo "<title>no page</title>"
rm -rf "$profile"
[ -s "$out" ]
