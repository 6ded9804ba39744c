#!/usr/bin/env bash
# Regenerates the notebooks and runs them headless (Debian's jupyter, numpy, matplotlib, pandas,
# scipy, opencv); figures land in notebooks/figures/. Needs a build (scripts/build.sh) and
# bench/results/bench_all.json (./build/aniso bench all --out bench/results/bench_all.json).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh --with-python
/usr/bin/python3 notebooks/make_notebooks.py
cd notebooks
for nb in bench_pareto fit_quality models_and_tables; do
  jupyter nbconvert --to notebook --execute --inplace --ExecutePreprocessor.timeout=600 "$nb.ipynb"
  echo "executed notebooks/$nb.ipynb"
done
ls -1 figures
