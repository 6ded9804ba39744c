#!/usr/bin/env bash
# Install, build, and run the main job on the built-in default (synth -> fit -> bake -> preview).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
./build/aniso demo --out demo_out
