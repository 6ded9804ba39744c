#!/usr/bin/env bash
# Frames per second of an export's three.js viewer in headless Chromium (SwiftShader: this
# machine's software GL), against the plainest lit shader on the same mesh in the same run.
# Usage: web/fps.sh EXPORT_DIR [SIZE] [FRAMES]     (a benchmark: prints, asserts nothing)
set -euo pipefail
dir=$1 size=${2:-1024} frames=${3:-120}
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
python3 -m http.server "$port" --bind 127.0.0.1 --directory "$dir" >/dev/null 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true' EXIT
sleep 1
for extra in "" "&plain=1"; do
  profile=$(mktemp -d)
  out=$( (timeout 120 chromium --headless=new --no-sandbox --use-angle=swiftshader \
    --enable-unsafe-swiftshader --user-data-dir="$profile" --window-size="$size,$size" \
    --enable-logging=stderr --v=0 \
    "http://127.0.0.1:$port/three/viewer.html?size=${size}x${size}&fps=$frames$extra" 2>&1 || true) |
    grep -m1 -o '"aniso viewer: fps[^"]*"' || true)
  echo "${out:-fps.sh: no figure (the page failed?)}"
  rm -rf "$profile"
done
