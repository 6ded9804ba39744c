#!/usr/bin/env bash
# Installs everything aniso needs from Debian 12's packages (nothing is downloaded at build time).
# Usage: scripts/install_deps.sh [--with-python]   (python: SciPy/matplotlib for bench/notebooks)
set -euo pipefail
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
PKGS=(build-essential cmake ninja-build pkg-config
      libceres-dev libeigen3-dev libopencv-dev libraw-dev libtiff-dev libpng-dev libjpeg-dev openmpi-bin libopenmpi-dev libopenexr-dev libimath-dev libembree-dev libtbb-dev
      libopengl-dev libegl-dev libgl-dev libgl1-mesa-dri libegl-mesa0 libepoxy-dev
      nlohmann-json3-dev libcli11-dev libgtest-dev libbenchmark-dev
      glslang-tools spirv-cross chromium libglfw3-dev libimgui-dev xvfb xauth)
# Node.js and npm (the export's checks: ktx-parse, gltf-validator, three.js): the machine's own
# when it has them (Debian's npm conflicts with a newer Node.js), Debian's otherwise.
command -v npm >/dev/null 2>&1 || PKGS+=(nodejs npm)
if [ "${1:-}" = "--with-python" ]; then
  PKGS+=(python3-numpy python3-scipy python3-matplotlib python3-pandas python3-opencv python3-nbformat
        jupyter-nbconvert python3-ipykernel)
fi
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PKGS[@]} packages present"
else
  echo "install_deps: installing ${#missing[@]} packages: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
# The independent readers the export is checked with (web/package-lock.json pins them): npm's
# registry, once; nothing is fetched at build time.
cd "$(dirname "$0")/.."
if ! cmp -s web/package-lock.json web/node_modules/.aniso-installed 2>/dev/null; then
  echo "install_deps: npm ci in web/ (ktx-parse, gltf-validator, three, babylonjs)"
  (cd web && npm ci --no-audit --no-fund --loglevel=error && cp package-lock.json node_modules/.aniso-installed)
fi
