#!/usr/bin/env bash
# Prints the include graph between the library's folders and fails on an arrow that does not point
# down, or on a folder that holds more than 3,000 lines in its own files:
#   core <- models <- geometry <- io <- {capture_sim, fit, render, photo} <- datasets_synth <- bench <- cli
# and inside a folder, its floors:
#   io/files <- io/images <- io/formats
#   render (its shaders: render/shaders_embedded.h, generated) <- render/bake
#     <- {render/preview, render/export} <- render/report
#   photo/shoot <- photo/lamps <- photo/import
#   fit/types <- fit/records <- fit/solvers <- {fit/global, fit/maps, fit/lamps} <- fit/output <- fit
#   cli (the entry point, the commands' registry and helpers, the fit's commands)
#     <- {cli/render, cli/photo} (the commands of the preview and export, of the photo shoot)
# A folder may include its own files and any folder of a lower rank; none of the same rank, so
# there can be no cycle. A sub-folder counts as its top folder toward other top folders.
# tests/ and fuzz/ sit on top of everything and are not checked.
set -euo pipefail
cd "$(dirname "$0")/.."
declare -A rank=([core]=0 [models]=1 [geometry]=2 [io]=3 [capture_sim]=4 [fit]=4 [render]=4 [photo]=4
                 [datasets_synth]=5 [bench]=6 [cli]=7)
declare -A floor=([io/files]=0 [io/images]=1 [io/formats]=2
                  [render]=0 [render/bake]=1 [render/preview]=2 [render/export]=2 [render/report]=3
                  [photo/shoot]=0 [photo/lamps]=1 [photo/import]=2
                  [fit/types]=0 [fit/records]=1 [fit/solvers]=2 [fit/global]=3 [fit/maps]=3 [fit/lamps]=3
                  [fit/output]=4 [fit]=5
                  [cli]=0 [cli/render]=1 [cli/photo]=1)
max_lines=3000
bad=0
declare -A edges=()
folders=()
for top in "${!rank[@]}"; do
  [ -d "$top" ] || continue
  folders+=("$top")
  while IFS= read -r sub; do folders+=("$sub"); done < <(find "$top" -mindepth 1 -type d | sort)
done
for from in "${folders[@]}"; do
  files=$(find "$from" -maxdepth 1 -type f \( -name '*.h' -o -name '*.cpp' -o -name '*.inc' \) | sort)
  [ -n "$files" ] || continue
  lines=$(cat $files | wc -l)
  if [ "$lines" -gt "$max_lines" ]; then
    echo "check_layers: $from/ holds $lines lines in its own files (at most $max_lines)" >&2
    bad=1
  fi
  top_from=${from%%/*}
  if [ "$top_from" != "$from" ] && [ -z "${floor[$from]+x}" ]; then
    echo "check_layers: $from/ is a sub-folder without a floor (add it to scripts/check_layers.sh)" >&2
    bad=1
    continue
  fi
  while IFS= read -r line; do
    [ -n "$line" ] || continue
    file=${line%%:*}
    path=$(sed -E 's/.*#include "([^"]+)".*/\1/' <<<"$line")
    to=$(dirname "$path")
    [ "$to" = "$from" ] && continue
    top_to=${to%%/*}
    if [ -z "${rank[$top_to]+x}" ]; then
      echo "check_layers: $file includes from '$to', a folder outside the layers" >&2
      bad=1
      continue
    fi
    edges["$from -> $to"]=$(( ${edges["$from -> $to"]:-0} + 1 ))
    if [ "$top_to" != "$top_from" ]; then
      if [ "${rank[$top_to]}" -ge "${rank[$top_from]}" ]; then
        echo "check_layers: UPWARD or sideways: $file includes $to/ (rank ${rank[$top_to]} >= ${rank[$top_from]})" >&2
        bad=1
      fi
    elif [ -z "${floor[$to]+x}" ] || [ -z "${floor[$from]+x}" ]; then
      echo "check_layers: $file includes $to/: sub-folders of $top_from/ without a floor" >&2
      bad=1
    elif [ "${floor[$to]}" -ge "${floor[$from]}" ]; then
      echo "check_layers: UPWARD or sideways inside $top_from/: $file includes $to/ (floor ${floor[$to]} >= ${floor[$from]})" >&2
      bad=1
    fi
  done < <(grep -Ho '#include "[a-z_]*/[^"]*"' $files 2>/dev/null || true)
done
echo "folder include graph (arrow = includes; count of include lines):"
for e in "${!edges[@]}"; do echo "  $e (${edges[$e]})"; done | sort
if [ "$bad" != 0 ]; then
  echo "check_layers: FAILED" >&2
  exit 1
fi
echo "check_layers: every arrow points down; no folder over $max_lines lines"
