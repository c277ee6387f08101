#!/usr/bin/env bash
# Fitting speed against scipy (least_squares from 32 starts, dual_annealing) on the bundled
# 213-point, three-incidence synthetic khaki dataset, measured in the same run.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! python3 -c "import scipy, numpy" 2>/dev/null; then
  python3 -m pip install --quiet numpy scipy || echo "scipy could not be installed; the peers will be skipped"
fi
cargo run --quiet --release -p brdf-bench -- fit "${1:-data/khaki-synthetic-inplane.csv}"
