#!/usr/bin/env bash
# The Python package's benchmarks, each in one Python process: `brdf.eval` against numpy on
# 10^6 points (bench/python_eval.py) and `brdf.fit` against scipy's 32-start least_squares
# (bench/python_fit.py; extra arguments go to it, e.g. a dataset). Uses the package's virtual
# environment (<target>/py-venv, <target> being cargo's target directory; built and tested by
# `cargo xtask test-python` when missing) and
# adds scipy to it, which the package's tests do not need.
set -euo pipefail
cd "$(dirname "$0")/.."
target=$(cargo metadata --format-version 1 --no-deps |
  python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')
py="$target/py-venv/bin/python"
if ! "$py" -c "import brdf" 2>/dev/null; then
  cargo xtask test-python
fi
if ! "$py" -c "import scipy" 2>/dev/null; then
  "$py" -m pip install --quiet --disable-pip-version-check scipy
fi
"$py" bench/python_eval.py
"$py" bench/python_fit.py "$@"
