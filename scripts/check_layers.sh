#!/usr/bin/env bash
# Prints the folder include graph of the library and fails on an arrow that does not point down:
#   core <- models <- geometry <- io <- {capture_sim, fit, render, photo} <- datasets_synth <- bench <- cli
# (a folder may include its own files and any folder of a lower rank; none of the same rank, so
# there can be no cycle). tests/ and fuzz/ sit on top of everything and are not checked.
set -euo pipefail
cd "$(dirname "$0")/.."
declare -A rank=([core]=0 [models]=1 [geometry]=2 [io]=3 [capture_sim]=4 [fit]=4 [render]=4 [photo]=4
                 [datasets_synth]=5 [bench]=6 [cli]=7)
bad=0
declare -A edges=()
for from in "${!rank[@]}"; do
  [ -d "$from" ] || continue
  while IFS= read -r line; do
    file=${line%%:*}
    to=$(sed -E 's/.*#include "([a-z_]+)\/.*/\1/' <<<"$line")
    [ "$to" = "$from" ] && continue
    if [ -z "${rank[$to]+x}" ]; then
      echo "check_layers: $file includes from '$to', a folder outside the layers" >&2
      bad=1
      continue
    fi
    edges["$from -> $to"]=$(( ${edges["$from -> $to"]:-0} + 1 ))
    if [ "${rank[$to]}" -ge "${rank[$from]}" ]; then
      echo "check_layers: UPWARD or sideways: $file includes $to/ (rank ${rank[$to]} >= ${rank[$from]})" >&2
      bad=1
    fi
  done < <(grep -Ho '#include "[a-z_]*/[^"]*"' "$from"/*.h "$from"/*.cpp 2>/dev/null || true)
done
echo "folder include graph (arrow = includes; count of include lines):"
for e in "${!edges[@]}"; do echo "  $e (${edges[$e]})"; done | sort
if [ "$bad" != 0 ]; then
  echo "check_layers: FAILED" >&2
  exit 1
fi
echo "check_layers: every arrow points down"
