#!/usr/bin/env bash
# Create (or reuse) a Python virtualenv with polars, pyarrow and pandas, used by
# tests that read mbmf's Parquet/Arrow output from Python.
#
#   scripts/python-env.sh [VENV_DIR]      (default: <repo>/.venv)
#
# The venv's python path is printed on the last line of stdout, so callers can do
#   PY="$(scripts/python-env.sh | tail -n1)"
# Progress messages go to stderr.
#
# Idempotent: a stamp file inside the venv records the pinned requirements; if it
# matches and the imports succeed, nothing is installed (takes well under a second).
# Override the base interpreter with PYTHON=/path/to/python3 (3.11 expected).
set -euo pipefail

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV_DIR="${1:-$REPO_ROOT/.venv}"
PYTHON="${PYTHON:-python3}"

# Pins known to install as binary wheels on CPython 3.11 / x86_64 here.
# polars >= 1.43 is needed for files written by parquet-rs >= 60, which declares the IEEE 754
# total order for float columns (PARQUET-2249); older polars fails with "Invalid thrift: bad data".
REQUIREMENTS=(
  "numpy==2.3.5"
  "pandas==2.3.3"
  "pyarrow==22.0.0"
  "polars==1.44.2"
)

log() { echo "python-env: $*" >&2; }
die() { echo "python-env: ERROR: $*" >&2; exit 1; }

command -v "$PYTHON" >/dev/null 2>&1 || die "base interpreter '$PYTHON' not found (set PYTHON=...)"

want_stamp="$(printf '%s\n' "${REQUIREMENTS[@]}")"
stamp="$VENV_DIR/.mbmf-requirements"
vpy="$VENV_DIR/bin/python"
check_imports=(-c "import polars, pyarrow, pandas")

# Fast path: already set up with the same pins and importable.
if [[ -x "$vpy" && -f "$stamp" ]] && [[ "$(cat "$stamp")" == "$want_stamp" ]] \
   && "$vpy" "${check_imports[@]}" >/dev/null 2>&1; then
  log "venv $VENV_DIR already up to date"
  echo "$vpy"
  exit 0
fi

if [[ ! -x "$vpy" ]] || ! "$vpy" -c "import sys" >/dev/null 2>&1; then
  base_ver="$("$PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
  [[ "$base_ver" == "3.11" ]] || log "warning: base python is $base_ver, pins were chosen for 3.11"
  log "creating venv $VENV_DIR with $("$PYTHON" -c 'import sys; print(sys.executable)') ($base_ver)"
  rm -rf "$VENV_DIR"
  "$PYTHON" -m venv "$VENV_DIR" || die "'$PYTHON -m venv $VENV_DIR' failed (is the venv/ensurepip module available?)"
fi

log "installing ${REQUIREMENTS[*]}"
export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1
if ! "$vpy" -m pip install --quiet --only-binary=:all: "${REQUIREMENTS[@]}" >&2; then
  die "pip install failed in $VENV_DIR (see pip's output above)"
fi

"$vpy" "${check_imports[@]}" || die "packages installed but 'import polars, pyarrow, pandas' fails"
printf '%s\n' "$want_stamp" >"$stamp"
log "ready: $("$vpy" -c 'import polars, pyarrow, pandas; print("polars", polars.__version__, "pyarrow", pyarrow.__version__, "pandas", pandas.__version__)')"
echo "$vpy"
