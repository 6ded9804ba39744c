#!/usr/bin/env bash
# Renders an export's glTF with a real engine's own loader (three.js GLTFLoader, Babylon.js) in
# headless Chromium (SwiftShader WebGL) under `aniso preview`'s camera and lights (web/engines.js):
# three (three.js GLTFLoader), babylon (Babylon.js), khronos (the Khronos glTF Sample Renderer).
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
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
python3 -m http.server "$port" --bind 127.0.0.1 --directory "$root" >/dev/null 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true; rm -rf "$root"' EXIT
for _ in $(seq 50); do
  python3 -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:$port/engines.html')" \
    2>/dev/null && break
  sleep 0.1
done
profile=$(mktemp -d)
url="http://127.0.0.1:$port/engines.html?engine=$engine&$query"
# The page writes its frame into the DOM: one bounded Chromium run gives the title and the picture
# (a second try if the first ends before the page has rendered).
for try in 1 2; do
  timeout 180 chromium --headless=new --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader \
    --user-data-dir="$profile" --window-size="$w,$h" --virtual-time-budget=30000 --dump-dom "$url" \
    2>/dev/null >"$root/dom.html" || true
  grep -q '<title>aniso engines: rendered</title>' "$root/dom.html" && break
done
grep -o '<title>[^<]*</title>' "$root/dom.html" || echo "<title>no page</title>"
rm -rf "$profile"
sed -n 's/.*<pre id="png">data:image\/png;base64,\([^<]*\)<\/pre>.*/\1/p' "$root/dom.html" | base64 -d >"$out"
[ -s "$out" ]
