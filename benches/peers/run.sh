#!/usr/bin/env bash
# Peer benchmark: sets up benches/peers/.venv if needed, then times each peer and the matching
# `mbmf run` on one pinned core (see run.py --help). Needs target/release/mbmf (cargo build
# --release) or MBMF=/path/to/mbmf.
#
#   benches/peers/run.sh                 # the full benchmark (a few minutes; 10 on a busy machine)
#   benches/peers/run.sh --quick         # a smoke test (under a minute)
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PY="$("$HERE/setup.sh" | tail -n1)"
exec "$PY" "$HERE/run.py" "$@"
