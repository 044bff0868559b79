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
# Idempotent: a stamp file inside the venv records the pinned requirements; if it matches and the
# imports succeed, nothing is installed. Override the base interpreter with PYTHON=/path/to/python3
# (3.11 expected).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
VENV_DIR="${1:-$HERE/.venv}"
PYTHON="${PYTHON:-python3}"

# Pins that install as binary wheels on CPython 3.11 / x86_64 (checked 2026-12-01).
REQUIREMENTS=(
  "numpy==2.3.5"
  "jax[cpu]==0.10.2"
  "jaxlib==0.10.2"
  "pyarrow==22.0.0"
  "threadpoolctl==3.6.0"
)

log() { echo "peers-setup: $*" >&2; }
die() { echo "peers-setup: ERROR: $*" >&2; exit 1; }

command -v "$PYTHON" >/dev/null 2>&1 || die "base interpreter '$PYTHON' not found (set PYTHON=...)"

want_stamp="$(printf '%s\n' "${REQUIREMENTS[@]}")"
stamp="$VENV_DIR/.peers-requirements"
vpy="$VENV_DIR/bin/python"
check_imports=(-c "import numpy, jax, pyarrow.parquet, threadpoolctl")

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
  "$PYTHON" -m venv "$VENV_DIR" || die "'$PYTHON -m venv $VENV_DIR' failed (is the venv module available?)"
fi

log "installing ${REQUIREMENTS[*]}"
export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1
if ! "$vpy" -m pip install --quiet --only-binary=:all: "${REQUIREMENTS[@]}" >&2; then
  die "pip install failed in $VENV_DIR (see pip's output above)"
fi

"$vpy" "${check_imports[@]}" || die "packages installed but the imports fail"
printf '%s\n' "$want_stamp" >"$stamp"
log "ready: $("$vpy" -c 'import numpy, jax, pyarrow; print("numpy", numpy.__version__, "jax", jax.__version__, "pyarrow", pyarrow.__version__)')"
echo "$vpy"
