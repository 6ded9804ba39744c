#!/usr/bin/env bash
# The test suite under AddressSanitizer and UndefinedBehaviorSanitizer (build-asan), all but the
# tests labelled `browser` (their time is headless Chromium's, and the files they load are written
# by code the `export` tests already run under the sanitizers) and the six in HEAVY: each runs at
# scale the fiber model's texels or evaluation, which lighter tests run under the sanitizers too
# (FitMaps.FiberModelSmoothingBringsNoisyTopologyCloser, FitMaps.LineMapsOfAFiberMaterialPoint-
# ToTheFiberModel, Trust.AFiberTexel*, FitFiber.FlatSamplesAcrossTopology, FiberModel.*), and
# together they were 346 of the 1 035 test-seconds of the sanitized run (517 s on two cores).
# -O1 -g1: the sanitizers' usual level, and line tables for their stack traces; -O2 -g compiled
# the sanitized library 2.9 times slower (fit/maps/texel_line.cpp: 245 s against 86 s).
# Leak detection is off: Mesa's llvmpipe and TBB keep allocations until exit by design.
# Extra args go to ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DANISO_SANITIZE=ON -DANISO_BUILD_BENCH=OFF \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DANISO_TEST_TIMEOUT=1800
cmake --build build-asan -j "$(nproc)"
HEAVY='^(FitMaps\.FiberModelMapsFitTheTopologyMapAmplitudePerTexel|FitMaps\.FiberTexelsTakeTheQuadratureOrderTheirValuesAllow|FitFiber\.FusedSolverAndCeresReachTheSameMinimum|FitMaps\.FiberTexelsWhereTheFibersClimbFindTheirOwnValley|FitMaps\.FusedFiberTexelsReachCeresMinimum|FiberModel\.MatchesBruteForceOverRandomAndAdversarialDirections)$'
ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -LE browser -E "$HEAVY" "$@"
