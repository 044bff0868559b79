#!/usr/bin/env bash
# Check that the local Slurm cluster (scripts/slurm-setup.sh) runs job arrays:
# submits `sbatch --array=0-2 --wait`, each task writing its SLURM_ARRAY_TASK_ID and
# SLURM_ARRAY_TASK_COUNT to a file, and checks the three files.
# Exit 0 on success, non-zero with a message (and the job's output) on failure.
#
#   SLURM_SELFTEST_TIMEOUT   seconds to wait for the array to finish (default 120)
set -euo pipefail

TIMEOUT="${SLURM_SELFTEST_TIMEOUT:-120}"
N=3

log() { echo "slurm-selftest: $*"; }
fail() { echo "slurm-selftest: FAIL: $*" >&2; exit 1; }

command -v sbatch >/dev/null || fail "sbatch not found: run scripts/slurm-setup.sh first"
sinfo -h >/dev/null 2>&1 || fail "slurmctld not answering (sinfo fails): run scripts/slurm-setup.sh first"

tmp="$(mktemp -d /tmp/mbmf-slurm-selftest.XXXXXX)"
chmod 755 "$tmp"
jobid=""
cleanup() {
  local rc=$?
  if [[ -n "$jobid" ]] && squeue -h -j "$jobid" 2>/dev/null | grep -q .; then
    scancel "$jobid" 2>/dev/null || true
  fi
  if ((rc == 0)); then
    rm -rf "$tmp"
  else
    echo "slurm-selftest: job files kept in $tmp" >&2
    for f in "$tmp"/*.out; do
      [[ -f "$f" ]] || continue
      echo "----- $f -----" >&2
      cat "$f" >&2
    done
  fi
}
trap cleanup EXIT

log "submitting array 0-$((N - 1)) (work dir $tmp)"
t0=$SECONDS
set +e
# Each task records its id/count, plus start/end times to see whether tasks overlapped
# (single quotes: the variables are expanded by the job, not here).
# shellcheck disable=SC2016
out="$(timeout "$TIMEOUT" sbatch --parsable --array=0-$((N - 1)) --wait \
  --job-name=mbmf-selftest --cpus-per-task=1 --time=5 \
  --chdir="$tmp" --output="$tmp/slurm-%A_%a.out" \
  --wrap='s=$(date +%s.%N); sleep 0.5
printf "%s %s\n" "$SLURM_ARRAY_TASK_ID" "$SLURM_ARRAY_TASK_COUNT" > "task_${SLURM_ARRAY_TASK_ID}.txt"
printf "%s %s\n" "$s" "$(date +%s.%N)" > "time_${SLURM_ARRAY_TASK_ID}.txt"' </dev/null 2>&1)"
rc=$?
set -e
jobid="$(printf '%s\n' "$out" | grep -Eo '^[0-9]+' | head -n1 || true)"
if ((rc == 124)); then
  squeue -j "$jobid" >&2 2>&1 || true
  scontrol show job "$jobid" >&2 2>&1 || true
  fail "array job ${jobid:-?} did not finish within ${TIMEOUT}s"
fi
((rc == 0)) || fail "sbatch --wait exited $rc: $out"
log "array job $jobid finished in $((SECONDS - t0))s"

for ((i = 0; i < N; i++)); do
  f="$tmp/task_$i.txt"
  [[ -f "$f" ]] || fail "missing $f (task $i did not run or could not write)"
  got="$(cat "$f")"
  [[ "$got" == "$i $N" ]] || fail "task $i wrote '$got', expected '$i $N' (SLURM_ARRAY_TASK_ID SLURM_ARRAY_TASK_COUNT)"
done
extra="$(find "$tmp" -name 'task_*.txt' | wc -l)"
((extra == N)) || fail "expected $N task files, found $extra"

# Informational: did at least two tasks run at the same time (select/cons_tres + CR_Core)?
overlap="$(cat "$tmp"/time_*.txt | awk '{s[NR]=$1; e[NR]=$2}
  END { for (i = 1; i <= NR; i++) for (j = i + 1; j <= NR; j++)
          if (s[i] < e[j] && s[j] < e[i]) { print "yes"; exit } print "no" }')"
if [[ "$overlap" == yes ]]; then
  log "array tasks ran concurrently"
else
  log "note: array tasks did not overlap in time (node may have only 1 CPU free)"
fi

log "OK: $N array tasks wrote the expected SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT"
