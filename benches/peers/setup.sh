#!/usr/bin/env bash
# Create (or reuse) the virtualenv of the peer benchmark: numpy and jax[cpu] for the peers,
# pyarrow to read mbmf's Parquet output when checking that the peers learn.
#
#   benches/peers/setup.sh [VENV_DIR]      (default: benches/peers/.venv)
#
# The venv's python path is printed on the last line of stdout, so callers can do
#   PY="$(benches/peers/setup.sh | tail -n1)"
# Progress messages go to stderr.
#
# Idempotent (scripts/venv.sh): a stamp file inside the venv records the pinned requirements; if
# it matches and the imports succeed, nothing is installed. Override the base interpreter with
# PYTHON=/path/to/python3 (3.11 expected).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
VENV_DIR="${1:-$HERE/.venv}"

# Pins that install as binary wheels on CPython 3.11 / x86_64 (checked 2026-12-01).
REQUIREMENTS=(
  "numpy==2.3.5"
  "jax[cpu]==0.10.2"
  "jaxlib==0.10.2"
  "pyarrow==22.0.0"
  "threadpoolctl==3.6.0"
)

LOG_NAME=peers-setup
source "$HERE/../../scripts/venv.sh"
venv_setup "$VENV_DIR" .peers-requirements "numpy, jax, pyarrow.parquet, threadpoolctl" \
  "${REQUIREMENTS[@]}"
echo "$VENV_DIR/bin/python"
