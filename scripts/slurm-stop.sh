#!/usr/bin/env bash
# Stop the local Slurm test cluster started by scripts/slurm-setup.sh:
# cancels this cluster's jobs, then stops slurmd, slurmctld and munged by their
# pid files (SIGTERM, then SIGKILL after 10 s).  Safe to run when nothing runs.
#
#   scripts/slurm-stop.sh              # stop everything
#   scripts/slurm-stop.sh --keep-munge # leave munged running
set -euo pipefail

KEEP_MUNGE=0
for a in "$@"; do
  case "$a" in
    --keep-munge) KEEP_MUNGE=1 ;;
    -h|--help) sed -n '2,8p' "$0"; exit 0 ;;
    *) echo "slurm-stop: unknown argument '$a'" >&2; exit 2 ;;
  esac
done

CTLD_PID=/run/slurmctld.pid
SLURMD_PID=/run/slurmd.pid
MUNGE_PID=/run/munge/munged.pid

log() { echo "slurm-stop: $*"; }

# alive, pid_of
# shellcheck source=scripts/slurm-pids.sh
. "$(dirname "${BASH_SOURCE[0]}")/slurm-pids.sh"

failed=0
stop() {
  local pidfile=$1 name=$2 pid i
  if ! pid="$(pid_of "$pidfile" "$name")"; then
    log "$name not running"
    return 0
  fi
  log "stopping $name (pid $pid)"
  kill -TERM "$pid" 2>/dev/null || true
  for ((i = 0; i < 100; i++)); do
    if ! alive "$pid"; then rm -f "$pidfile"; return 0; fi
    sleep 0.1
  done
  log "$name (pid $pid) still alive after 10s: sending SIGKILL"
  kill -KILL "$pid" 2>/dev/null || true
  sleep 0.5
  if alive "$pid"; then
    echo "slurm-stop: ERROR: could not stop $name (pid $pid)" >&2
    failed=1
  else
    rm -f "$pidfile"
  fi
}

# Cancel queued/running jobs first so no slurmstepd is left behind.
if pid_of "$CTLD_PID" slurmctld >/dev/null && command -v squeue >/dev/null; then
  if jobs="$(squeue -h -o '%A' 2>/dev/null)" && [[ -n "$jobs" ]]; then
    log "cancelling jobs: $(tr '\n' ' ' <<<"$jobs")"
    # shellcheck disable=SC2086
    scancel $jobs 2>/dev/null || true
    for ((i = 0; i < 50; i++)); do
      [[ -z "$(squeue -h -o '%A' 2>/dev/null)" ]] && break
      sleep 0.2
    done
  fi
fi

stop "$SLURMD_PID" slurmd
stop "$CTLD_PID" slurmctld
((KEEP_MUNGE)) || stop "$MUNGE_PID" munged

# Job steps (slurmstepd) normally end with their jobs, cancelled above; just report any left.
if command -v pgrep >/dev/null && left="$(pgrep -x slurmstepd)"; then
  log "warning: slurmstepd processes still running: $(tr '\n' ' ' <<<"$left")"
fi

if ((failed)); then exit 1; fi
log "stopped"
