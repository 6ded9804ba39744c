#!/usr/bin/env bash
# Packs the build as a Debian package, installs it with apt as a person would
# (`apt install ./aniso_*.deb`), runs the installed commands from /usr with the source tree out of
# reach (a fresh working folder, ANISO_THREE_DIR unset), and removes the package again. CI runs it
# after the tests (.ci/run); it needs root or sudo, and the packages scripts/install_deps.sh put in.
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
if dpkg-query -W -f='${Status}' aniso 2>/dev/null | grep -q "install ok installed"; then
  echo "check_package: a package named aniso is installed already; not replacing it" >&2
  exit 1
fi
log=$(mktemp)
quiet() { "$@" > "$log" 2>&1 || { cat "$log" >&2; echo "check_package: failed: $*" >&2; exit 1; }; }
(cd build && rm -f aniso_*.deb)
quiet cpack --config build/CPackConfig.cmake -G DEB -B build
deb=$(ls build/aniso_*.deb)
echo "check_package: $deb ($(du -h "$deb" | cut -f1))"
quiet env DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "./$deb"
work=$(mktemp -d)
trap 'DEBIAN_FRONTEND=noninteractive $SUDO apt-get remove -y -qq aniso > /dev/null; rm -rf "$work" "$log"' EXIT
cd "$work"
bin=$(command -v aniso)
[ "$bin" = /usr/bin/aniso ] || { echo "check_package: aniso is $bin, not /usr/bin/aniso" >&2; exit 1; }
env -u ANISO_THREE_DIR aniso --version
env -u ANISO_THREE_DIR aniso synth brushed-metal set --views 4 --size 32x32 > /dev/null
env -u ANISO_THREE_DIR aniso fit set --out m.json > /dev/null
env -u ANISO_THREE_DIR aniso export m.json --out export --size 16 > /dev/null
grep -q 'copied from /usr/share/aniso/three' export/export.json || {
  echo "check_package: the installed export did not take /usr/share/aniso/three" >&2
  exit 1
}
[ -f export/three/three.module.js ] || { echo "check_package: no three.js in the export" >&2; exit 1; }
echo "check_package: installed from the .deb, synth, fit and export ran from /usr; removed again"
