#!/usr/bin/env bash
# Configures and builds aniso (and aniso-full, aniso-mpi beside it) in ./build (Release, Ninja,
# all cores). Extra args go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DANISO_MPI=ON "$@"
cmake --build build -j "$(nproc)"
