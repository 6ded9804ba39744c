#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) in build-fuzz and runs each for
# ${1:-60} seconds, seeded with the test inputs. Crashes land in build-fuzz/crash-*.
set -euo pipefail
cd "$(dirname "$0")/.."
SECS=${1:-60}
SUDO=""; [ "$(id -u)" != 0 ] && SUDO="sudo"
dpkg-query -W clang libclang-rt-14-dev >/dev/null 2>&1 ||
  { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends clang libclang-rt-14-dev; }
scripts/install_deps.sh
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DANISO_FUZZ=ON \
  -DANISO_WERROR=OFF -DANISO_BUILD_BENCH=OFF
cmake --build build-fuzz -j "$(nproc)" --target fuzz_model fuzz_readers aniso
mkdir -p build-fuzz/corpus_readers build-fuzz/corpus_model
# A real capture set (EXR and 8-bit PNG) whose files exist, so decoding is actually reached.
rm -rf build-fuzz/seedset build-fuzz/seedpng
build-fuzz/aniso synth brushed-metal build-fuzz/seedset --views 2 --size 8 >/dev/null
build-fuzz/aniso synth brushed-metal build-fuzz/seedpng --views 1 --size 8 --bits 8 --encoding srgb >/dev/null
{ printf '\x00'; cat build-fuzz/seedset/capture.json; } > build-fuzz/corpus_readers/capture_real
{ printf '\x04'; cat build-fuzz/seedset/images/000.exr; } > build-fuzz/corpus_readers/exr_real
{ printf '\x03'; cat build-fuzz/seedpng/images/000.png; } > build-fuzz/corpus_readers/png_real
{ printf '\x01'; cat build-fuzz/seedset/truth.json; } > build-fuzz/corpus_readers/material_real
rm -rf build-fuzz/seedboard && mkdir -p build-fuzz/seedboard
build-fuzz/aniso board --out build-fuzz/seedboard/board.png --dpi 30 >/dev/null
{ printf '\x06'; cat build-fuzz/seedboard/shoot.json; } > build-fuzz/corpus_readers/shoot
export ANISO_FUZZ_SET="$PWD/build-fuzz/seedset"
# Seeds: one of each file kind, prefixed with its reader-selector byte.
printf '\x01{"format":"aniso-material","version":1,"kd":0.2,"ks":0.5,"n":10,"fiber_angle_deg":0}' > build-fuzz/corpus_readers/material
printf '\x02theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,y\n30,0,40,180,0.5\n' > build-fuzz/corpus_readers/table
printf '\x05v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n' > build-fuzz/corpus_readers/obj
printf '\x00{"format":"aniso-capture","version":1,"camera":{"width":2,"height":2,"fx":1,"fy":1,"cx":0,"cy":0},"geometry":{"mesh":"m.obj"},"views":[{"image":"i.exr","world_from_camera":[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],"lights":[{"type":"point","position":[0,0,1],"intensity":1}]}]}' > build-fuzz/corpus_readers/capture
cd build-fuzz
./fuzz/fuzz_model -max_total_time="$SECS" corpus_model 2>&1 | tail -3
./fuzz/fuzz_readers -max_total_time="$SECS" corpus_readers 2>&1 | tail -3
