#!/usr/bin/env bash
# Per-texel maps of one capture set over many machines with Slurm: one job fits the global
# parameters (`aniso fit CAPTURE --subsample $GLOBAL_SUBSAMPLE --keep-anisotropic`, into
# OUT_DIR/global.json), then a
# job array whose task i fits the texel rows of tile i of N from it (`aniso fit --maps WxH
# --global OUT_DIR/global.json --tile i/N`: each task keeps only the pixels whose uv falls in its
# rows), then a job that runs when all of them succeeded and merges the tiles (`aniso merge`) into
# OUT_DIR/material.json and its maps: the same files as one untiled run with that global fit.
#
#   scripts/slurm_maps.sh submit CAPTURE WxH N OUT_DIR [sbatch options...]   # on a Slurm login node
#   scripts/slurm_maps.sh local  CAPTURE WxH N OUT_DIR                       # the same jobs, here, in turn
#
# ANISO (default: build/aniso beside this script) names the binary; every node must reach it,
# CAPTURE and OUT_DIR (a shared file system). GLOBAL_SUBSAMPLE (default 1) thins the global fit's
# pixels; MODEL (line or fiber, default line) is every fit's; FIT_OPTIONS are added to every tile's
# fit (e.g. "--smooth 1"). See BENCHMARKS.md, "Maps past one machine", for what each part costs.
set -euo pipefail
mode=${1:-}; capture=${2:-}; grid=${3:-}; n=${4:-}; out=${5:-}
if [ -z "$out" ] || { [ "$mode" != submit ] && [ "$mode" != local ]; }; then
  sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
shift 5
aniso=${ANISO:-"$(cd "$(dirname "$0")/.." && pwd)/build/aniso"}
[ -x "$aniso" ] || { echo "slurm_maps: $aniso is not an executable (set ANISO)" >&2; exit 1; }
[ "$n" -ge 1 ] 2>/dev/null || { echo "slurm_maps: N must be a positive integer, got '$n'" >&2; exit 1; }
mkdir -p "$out/tiles"
tiles=()
for ((i = 0; i < n; i++)); do tiles+=("$out/tiles/tile_$i.json"); done
global="\"$aniso\" fit \"$capture\" --model ${MODEL:-line} --subsample ${GLOBAL_SUBSAMPLE:-1} --keep-anisotropic --out \"$out/global.json\""
task="\"$aniso\" fit \"$capture\" --maps $grid --model ${MODEL:-line} ${FIT_OPTIONS:-} --global \"$out/global.json\" --tile \${SLURM_ARRAY_TASK_ID}/$n --out \"$out/tiles/tile_\${SLURM_ARRAY_TASK_ID}.json\""
merge="\"$aniso\" merge ${tiles[*]} --out \"$out/material.json\""
if [ "$mode" = local ]; then
  bash -c "$global" | grep -E "^fit: wrote" || exit 1
  for ((i = 0; i < n; i++)); do SLURM_ARRAY_TASK_ID=$i bash -c "eval $task" | grep -E "^fit: tile" || exit 1; done
  bash -c "$merge"
  exit 0
fi
command -v sbatch >/dev/null || { echo "slurm_maps: sbatch not found (no Slurm here: try 'local')" >&2; exit 1; }
first=$(sbatch --parsable --job-name=aniso-global "$@" --wrap "$global")
echo "slurm_maps: global fit: job $first -> $out/global.json"
array=$(sbatch --parsable --job-name=aniso-maps --dependency=afterok:"${first%%;*}" --array=0-$((n - 1)) "$@" --wrap "$task")
echo "slurm_maps: tiles: job array $array (N = $n)"
merged=$(sbatch --parsable --job-name=aniso-merge --dependency=afterok:"${array%%;*}" "$@" --wrap "$merge")
echo "slurm_maps: merge: job $merged, after every tile succeeded -> $out/material.json"
