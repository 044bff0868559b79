# Sourced by scripts/python-env.sh and benches/peers/setup.sh: one virtualenv with pinned
# requirements, reused while the stamp file inside it lists the same pins and the imports work.
#
#   LOG_NAME=NAME; source scripts/venv.sh
#   venv_setup VENV_DIR STAMP_NAME IMPORTS REQUIREMENT...
#
# Progress messages go to stderr, prefixed with NAME. Override the base interpreter with
# PYTHON=/path/to/python3 (3.11 expected).

PYTHON="${PYTHON:-python3}"

log() { echo "$LOG_NAME: $*" >&2; }
die() { echo "$LOG_NAME: ERROR: $*" >&2; exit 1; }

command -v "$PYTHON" >/dev/null 2>&1 || die "base interpreter '$PYTHON' not found (set PYTHON=...)"

# venv_setup VENV_DIR STAMP_NAME IMPORTS REQUIREMENT...: the stamp is VENV_DIR/STAMP_NAME, one
# requirement a line; IMPORTS is what `import IMPORTS` must load.
venv_setup() {
  local dir="$1" stamp="$1/$2" imports="$3"
  shift 3
  local want_stamp vpy base_ver
  want_stamp="$(printf '%s\n' "$@")"
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
  log "ready: $dir: $*"
}
