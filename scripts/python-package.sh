#!/usr/bin/env bash
# Build the Python package (python/) from this checkout into <repo>/.venv-pkg and test it:
# pytest python/tests, then mypy's stubtest of the hand-written stubs.
#
#   scripts/python-package.sh [VENV_DIR]
#
# Idempotent like scripts/python-env.sh (scripts/venv.sh): the venv's pinned tools are installed
# once; the package is rebuilt each time (cargo reuses <repo>/target, shared with the CLI build,
# so an unchanged checkout rebuilds nothing). pytest finding no test is a failure.
set -euo pipefail

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV_DIR="${1:-$REPO_ROOT/.venv-pkg}"

# polars and pyarrow as in scripts/python-env.sh; tqdm for the progress bar's test.
TOOLS=(
  "maturin==1.9.6"
  "pytest==8.4.2"
  "mypy==1.18.2"
  "numpy==2.3.5"
  "pyarrow==22.0.0"
  "polars==2.1.0"
  "tqdm==4.67.1"
)

LOG_NAME=python-package
source "$REPO_ROOT/scripts/venv.sh"

venv_setup "$VENV_DIR" .mbmf-requirements "maturin, pytest, mypy, polars, pyarrow, tqdm" "${TOOLS[@]}"
VPY="$VENV_DIR/bin/python"

# The root's `cargo clippy` lints the root package only: lint the binding here.
log "cargo clippy -p mbmf-python"
(cd "$REPO_ROOT" && PYO3_PYTHON="$VPY" cargo clippy --release --quiet -p mbmf-python -- -D warnings)

log "building the package (release) into $VENV_DIR"
export CARGO_TARGET_DIR="$REPO_ROOT/target"
# maturin develop installs into the venv it runs from; it needs VIRTUAL_ENV to find it.
(
  cd "$REPO_ROOT/python"
  VIRTUAL_ENV="$VENV_DIR" PATH="$VENV_DIR/bin:$PATH" "$VENV_DIR/bin/maturin" develop --release --quiet >&2
)

# The CLI binary the equality tests compare with, from this checkout (a no-op after cargo test).
(cd "$REPO_ROOT" && cargo build --release --quiet)

log "pytest python/tests"
set +e
MBMF_BIN="$REPO_ROOT/target/release/mbmf" "$VPY" -m pytest -q "$REPO_ROOT/python/tests"
code=$?
set -e
if [[ $code -eq 5 ]]; then
  die "pytest collected no test in python/tests"
elif [[ $code -ne 0 ]]; then
  die "pytest failed (exit $code)"
fi

log "stubtest mbmf"
(cd "$REPO_ROOT" && "$VPY" -m mypy.stubtest mbmf)
log "ok"
