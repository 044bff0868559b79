#!/usr/bin/env bash
# Set up what the browser tests (tests/browser/teach_browser.py) need:
#
#   - Debian's `chromium` and `chromium-driver` (/usr/bin/chromium, /usr/bin/chromedriver), with
#     apt-get when either is missing (run as root; no sudo);
#   - `selenium` in the project's venv (<repo>/.venv by default, the one scripts/python-env.sh
#     makes), recorded by its own stamp file so the two scripts do not undo each other.
#
#   scripts/browser-env.sh [VENV_DIR]
#
# The venv's python path is printed on the last line of stdout, so callers can do
#   PY="$(scripts/browser-env.sh | tail -n1)"
# Progress messages go to stderr. Idempotent: when Chromium, chromedriver and the pinned selenium
# are already there, nothing is installed (takes well under a second).
# Override the base interpreter with PYTHON=/path/to/python3 (3.11 expected).
set -euo pipefail

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV_DIR="${1:-$REPO_ROOT/.venv}"

# Selenium drives the system chromedriver given by path, so its own driver download
# (Selenium Manager) is never needed. 4.52 wants a certifi newer than the registry here has.
BROWSER_REQS=(
  "selenium==4.50.0"
)

LOG_NAME=browser-env
source "$REPO_ROOT/scripts/venv.sh"

if [[ ! -x /usr/bin/chromium || ! -x /usr/bin/chromedriver ]]; then
  command -v apt-get >/dev/null 2>&1 || die "/usr/bin/chromium or /usr/bin/chromedriver is missing and apt-get is not available"
  [[ "$(id -u)" == 0 ]] || die "/usr/bin/chromium or /usr/bin/chromedriver is missing; installing them needs root"
  log "installing chromium and chromium-driver with apt-get"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >&2 || die "apt-get update failed"
  apt-get install -y -qq --no-install-recommends chromium chromium-driver >&2 \
    || die "apt-get install chromium chromium-driver failed"
  [[ -x /usr/bin/chromium && -x /usr/bin/chromedriver ]] \
    || die "apt-get finished but /usr/bin/chromium or /usr/bin/chromedriver is still missing"
  log "ready: $(/usr/bin/chromium --version 2>/dev/null || echo chromium)"
else
  log "chromium and chromedriver already installed"
fi

venv_setup "$VENV_DIR" .mbmf-browser-requirements "selenium" "${BROWSER_REQS[@]}"
echo "$VENV_DIR/bin/python"
