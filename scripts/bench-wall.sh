#!/usr/bin/env bash
# Wall time of whole `mbmf run` commands, two binaries interleaved, median of R repeats, for a
# quiet machine (close other work first: on a shared machine the figures measure the load).
#
#   scripts/bench-wall.sh OLD_BINARY NEW_BINARY [REPEATS]     # default 5 repeats
#
# Jobs: mf 4,096 runs x (1,000 babbling + 2,000 steps) and ec 1,024 runs x 1,000 steps with no
# babbling (the early phase), each on 1 thread pinned to core 0 and on 2 threads (cores 0-1);
# prints one line per job and binary: the median wall seconds and the 2-thread speed-up.
set -euo pipefail
OLD="$1"; NEW="$2"; R="${3:-5}"
WORK="$(mktemp -d)"; trap 'rm -rf "$WORK"' EXIT
jobs=(
  "mf|--controller mf --runs 4096 --steps 2000 --babbling 1000"
  "ec-early|--controller ec --runs 1024 --steps 1000 --babbling 0"
)
declare -A times
for bin in "$OLD" "$NEW"; do "$bin" run --runs 1 --steps 10 --out "$WORK/warm" --force -q >/dev/null; done
for ((i = 0; i < R; i++)); do
  for job in "${jobs[@]}"; do
    name="${job%%|*}"; args="${job#*|}"
    for who in old new; do
      bin="$OLD"; [ "$who" = new ] && bin="$NEW"
      for t in 1 2; do
        cores=0; [ "$t" = 2 ] && cores=0-1
        start=$(date +%s.%N)
        # shellcheck disable=SC2086
        taskset -c "$cores" "$bin" run $args --threads "$t" --out "$WORK/o" --force -q >/dev/null
        end=$(date +%s.%N)
        times["$name $who $t"]+="$(echo "$end - $start" | bc) "
      done
    done
  done
done
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{a[NR]=$1} END {print a[int((NR + 1) / 2)]}'; }
printf '%-9s %-4s %10s %10s %8s\n' job bin "1 thread" "2 threads" speed-up
for job in "${jobs[@]}"; do
  name="${job%%|*}"
  for who in old new; do
    one=$(echo "${times["$name $who 1"]}" | median)
    two=$(echo "${times["$name $who 2"]}" | median)
    printf '%-9s %-4s %9.3fs %9.3fs %7.2fx\n' "$name" "$who" "$one" "$two" "$(echo "$one / $two" | bc -l)"
  done
done
