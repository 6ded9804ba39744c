#!/usr/bin/env bash
# Renders an export's glTF with a real engine's own loader in headless Chromium (SwiftShader
# WebGL) under `aniso preview`'s camera and lights (web/engines.js): three (three.js GLTFLoader),
# babylon (Babylon.js), khronos (the Khronos glTF Sample Renderer).
# Prints the page title ("rendered" or the error).
# Usage: web/engines.sh EXPORT_DIR ENGINE 'QUERY' OUT.png W H
set -euo pipefail
web=$(cd "$(dirname "$0")" && pwd)
dir=$(cd "$1" && pwd) engine=$2 query=$3 out=$4 w=$5 h=$6
root=$(mktemp -d)
ln -s "$dir" "$root/export"
for p in three babylonjs babylonjs-loaders; do ln -s "$web/node_modules/$p" "$root/$p"; done
ln -s "$web/node_modules/@khronosgroup/gltf-viewer" "$root/gltf-viewer"
cp "$web/engines.html" "$web/engines.js" "$root/"
source "$web/serve.sh"
server=
trap 'kill $server 2>/dev/null || true; rm -rf "$root"' EXIT
serve "$root" engines.html
url="http://127.0.0.1:$port/engines.html?engine=$engine&$query"
# The page writes its frame into the DOM once rendered; web/render_page.mjs waits for it in real
# time (at most 150 s) and writes it out.
node "$web/render_page.mjs" "$url" "aniso engines: " "$out" "$w" "$h" 150 \
  2>/dev/null || true
[ -s "$out" ]
