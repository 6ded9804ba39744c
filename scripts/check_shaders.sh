#!/usr/bin/env bash
# Compiles every GLSL file of the preview (render/shaders/) with Khronos' reference front end,
# glslangValidator (Debian glslang-tools), outside any driver: a shader that only Mesa accepts
# fails here. Usage: scripts/check_shaders.sh [FILE...]   (default: render/shaders/*)
set -euo pipefail
cd "$(dirname "$0")/.."
command -v glslangValidator >/dev/null ||
  { echo "check_shaders: glslangValidator not found (scripts/install_deps.sh installs it)" >&2; exit 1; }
files=("$@")
[ ${#files[@]} -gt 0 ] || files=(render/shaders/*)
bad=0
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for f in "${files[@]}"; do
  # A .glsl file is a part spliced into the shaders that name it ("// aniso: maps.glsl"), as
  # render/preview/preview.cpp does: checked there, in place.
  [[ $f == *.glsl ]] && continue
  src=$f
  if grep -q '^// aniso: [a-z_]*\.glsl$' "$f"; then
    src="$tmp/$(basename "$f")"
    awk -v dir="$(dirname "$f")" '/^\/\/ aniso: [a-z_]*\.glsl$/ { while ((getline l < (dir "/" $3)) > 0) print l; next } { print }' "$f" >"$src"
  fi
  if out=$(glslangValidator "$src" 2>&1); then
    echo "check_shaders: ok   $f"
  else
    echo "check_shaders: FAIL $f"; echo "$out" | sed 's/^/    /'; bad=1
  fi
done
exit $bad
