#!/usr/bin/env bash
# Per-texel maps of one capture set over many machines with Slurm: a job array whose task i fits
# the texel rows of tile i of N (`aniso fit --maps WxH --tile i/N`), then a job that runs when all
# of them succeeded and merges the tiles (`aniso merge`) into OUT_DIR/material.json and its maps,
# the same files as one untiled run.
#
#   scripts/slurm_maps.sh submit CAPTURE WxH N OUT_DIR [sbatch options...]   # on a Slurm login node
#   scripts/slurm_maps.sh local  CAPTURE WxH N OUT_DIR                       # the same tasks, here, in turn
#
# ANISO (default: build/aniso beside this script) names the binary; every node must reach it,
# CAPTURE and OUT_DIR (a shared file system). Each task loads the whole capture and repeats the
# global fit (see BENCHMARKS.md, "Maps past one machine", for what that costs).
set -euo pipefail
mode=${1:-}; capture=${2:-}; grid=${3:-}; n=${4:-}; out=${5:-}
if [ -z "$out" ] || { [ "$mode" != submit ] && [ "$mode" != local ]; }; then
  sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
shift 5
aniso=${ANISO:-"$(cd "$(dirname "$0")/.." && pwd)/build/aniso"}
[ -x "$aniso" ] || { echo "slurm_maps: $aniso is not an executable (set ANISO)" >&2; exit 1; }
[ "$n" -ge 1 ] 2>/dev/null || { echo "slurm_maps: N must be a positive integer, got '$n'" >&2; exit 1; }
mkdir -p "$out/tiles"
tiles=()
for ((i = 0; i < n; i++)); do tiles+=("$out/tiles/tile_$i.json"); done
task="\"$aniso\" fit \"$capture\" --maps $grid --tile \${SLURM_ARRAY_TASK_ID}/$n --out \"$out/tiles/tile_\${SLURM_ARRAY_TASK_ID}.json\""
merge="\"$aniso\" merge ${tiles[*]} --out \"$out/material.json\""
if [ "$mode" = local ]; then
  for ((i = 0; i < n; i++)); do SLURM_ARRAY_TASK_ID=$i bash -c "eval $task" | grep -E "^fit: tile" || exit 1; done
  bash -c "$merge"
  exit 0
fi
command -v sbatch >/dev/null || { echo "slurm_maps: sbatch not found (no Slurm here: try 'local')" >&2; exit 1; }
array=$(sbatch --parsable --job-name=aniso-maps --array=0-$((n - 1)) "$@" --wrap "$task")
echo "slurm_maps: tiles: job array $array (N = $n)"
merged=$(sbatch --parsable --job-name=aniso-merge --dependency=afterok:"${array%%;*}" "$@" --wrap "$merge")
echo "slurm_maps: merge: job $merged, after every tile succeeded -> $out/material.json"
