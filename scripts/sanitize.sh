#!/usr/bin/env bash
# The whole test suite under AddressSanitizer and UndefinedBehaviorSanitizer (build-asan).
# Leak detection is off: Mesa's llvmpipe and TBB keep allocations until exit by design.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DANISO_SANITIZE=ON -DANISO_BUILD_BENCH=OFF \
  -DANISO_TEST_TIMEOUT=1800
cmake --build build-asan -j "$(nproc)"
ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j "$(nproc)" "$@"
