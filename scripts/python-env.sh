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
# Idempotent: a stamp file inside each venv records its pinned requirements; if it matches and
# the imports succeed, nothing is installed (takes well under a second).
# Override the base interpreter with PYTHON=/path/to/python3 (3.11 expected).
set -euo pipefail

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV_DIR="${1:-$REPO_ROOT/.venv}"
OLD_VENV_DIR="${2:-$REPO_ROOT/.venv-old}"
PYTHON="${PYTHON:-python3}"

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

log() { echo "python-env: $*" >&2; }
die() { echo "python-env: ERROR: $*" >&2; exit 1; }

command -v "$PYTHON" >/dev/null 2>&1 || die "base interpreter '$PYTHON' not found (set PYTHON=...)"

# setup VENV_DIR IMPORTS REQUIREMENT...
setup() {
  local dir="$1" imports="$2"
  shift 2
  local want_stamp stamp vpy base_ver
  want_stamp="$(printf '%s\n' "$@")"
  stamp="$dir/.mbmf-requirements"
  vpy="$dir/bin/python"
  if [[ -x "$vpy" && -f "$stamp" ]] && [[ "$(cat "$stamp")" == "$want_stamp" ]] \
     && "$vpy" -c "import $imports" >/dev/null 2>&1; then
    log "venv $dir already up to date"
    return 0
  fi
  if [[ ! -x "$vpy" ]] || ! "$vpy" -c "import sys" >/dev/null 2>&1; then
    base_ver="$("$PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
    [[ "$base_ver" == "3.11" ]] || log "warning: base python is $base_ver, pins were chosen for 3.11"
    log "creating venv $dir with $("$PYTHON" -c 'import sys; print(sys.executable)') ($base_ver)"
    rm -rf "$dir"
    "$PYTHON" -m venv "$dir" || die "'$PYTHON -m venv $dir' failed (is the venv/ensurepip module available?)"
  fi
  log "installing into $dir: $*"
  export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1
  if ! "$vpy" -m pip install --quiet --only-binary=:all: "$@" >&2; then
    die "pip install failed in $dir (see pip's output above)"
  fi
  "$vpy" -c "import $imports" || die "packages installed in $dir but 'import $imports' fails"
  printf '%s\n' "$want_stamp" >"$stamp"
  log "ready: $dir: $("$vpy" -m pip freeze 2>/dev/null | grep -iE '^(polars|pyarrow|pandas|duckdb)==' | tr '\n' ' ')"
}

setup "$OLD_VENV_DIR" "polars, pyarrow" "${OLD[@]}"
setup "$VENV_DIR" "polars, pyarrow, pandas, duckdb" "${CURRENT[@]}"
echo "$VENV_DIR/bin/python"
