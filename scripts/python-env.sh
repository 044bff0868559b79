#!/usr/bin/env bash
# Create (or reuse) the Python virtualenvs that tests use to read mbmf's Parquet output with the
# readers researchers have:
#
#   <repo>/.venv      current readers: polars, pandas, pyarrow, duckdb
#   <repo>/.venv-old  an old polars (1.20) and pyarrow 14, as clusters and conda pins still ship
#
#   scripts/python-env.sh [VENV_DIR [OLD_VENV_DIR]]
#
# The current venv's python path is printed on the last line of stdout, so callers can do
#   PY="$(scripts/python-env.sh | tail -n1)"
# (the old venv's python is <OLD_VENV_DIR>/bin/python). Progress messages go to stderr.
#
# Idempotent (scripts/venv.sh): a stamp file inside each venv records its pinned requirements; if
# it matches and the imports succeed, nothing is installed (takes well under a second).
# Override the base interpreter with PYTHON=/path/to/python3 (3.11 expected).
set -euo pipefail

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV_DIR="${1:-$REPO_ROOT/.venv}"
OLD_VENV_DIR="${2:-$REPO_ROOT/.venv-old}"

# Pins known to install as binary wheels on CPython 3.11 / x86_64 here.
CURRENT=(
  "numpy==2.3.5"
  "pandas==2.3.3"
  "pyarrow==22.0.0"
  "polars==2.1.0"
  "duckdb==1.4.4"
)
# Polars before 1.43 refuses files that declare the IEEE 754 total order for float columns
# (parquet-rs >= 60 writes it); pyarrow 14 then hides float statistics. These two guard that.
# pyarrow 14 was built against numpy 1.x.
OLD=(
  "numpy==1.26.4"
  "pyarrow==14.0.2"
  "polars==1.20.0"
)

LOG_NAME=python-env
source "$REPO_ROOT/scripts/venv.sh"

venv_setup "$OLD_VENV_DIR" .mbmf-requirements "polars, pyarrow" "${OLD[@]}"
venv_setup "$VENV_DIR" .mbmf-requirements "polars, pyarrow, pandas, duckdb" "${CURRENT[@]}"
echo "$VENV_DIR/bin/python"
