#!/usr/bin/env bash
# Runs the same `mbmf run` commands with two binaries and compares every column of runs.parquet
# and series.parquet but wall_time_s (columns only the new binary writes may be listed in
# NEWCOLS=a,b,...). The check behind "results do not move" after an engine change:
#
#   scripts/compare-outputs.sh OLD_BINARY NEW_BINARY
#
# Needs the venv of scripts/python-env.sh (pyarrow) and the authors' navigation data at
# ../shared/data/navworld for the cases that read it. Exit 0 when every case is identical.
set -u
OLD="$1"; NEW="$2"
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="$("$REPO/scripts/python-env.sh" 2>/dev/null | tail -n1)"
NAV="$REPO/../shared/data/navworld"
WORK="$(mktemp -d)"; trap 'rm -rf "$WORK"' EXIT
fail=0
while IFS='|' read -r name args; do
  [ -z "$name" ] && continue
  for who in old new; do
    bin="$OLD"; [ "$who" = new ] && bin="$NEW"
    # shellcheck disable=SC2086
    "$bin" run $args --out "$WORK/$who-$name" -q >/dev/null 2>"$WORK/$who-$name.err" \
      || { echo "$name: $who failed: $(cat "$WORK/$who-$name.err")"; fail=1; continue 2; }
  done
  "$PY" - "$WORK" "$name" <<'PYEOF' || fail=1
import os, sys
import pyarrow.parquet as pq
work, name = sys.argv[1], sys.argv[2]
allowed = set(filter(None, os.environ.get("NEWCOLS", "").split(",")))
for table in ("runs", "series"):
    a = pq.read_table(f"{work}/old-{name}/{table}.parquet")
    b = pq.read_table(f"{work}/new-{name}/{table}.parquet")
    missing = set(a.column_names) - set(b.column_names)
    extra = set(b.column_names) - set(a.column_names) - allowed
    if missing or extra:
        sys.exit(f"{name} {table}: columns differ: missing {missing}, unexpected {extra}")
    for column in a.column_names:
        if column != "wall_time_s" and not a.column(column).equals(b.column(column)):
            sys.exit(f"{name} {table}: column {column} differs")
print(f"{name}: identical ({a.num_rows} series rows)")
PYEOF
done <<EOF2
base|--controller mf,mb,rnd,ec,entropy --runs 6 --steps 3000
tidy2|--task tidy2 --controller mf,mb,rnd,ec,entropy --runs 4 --steps 3000
congr|--controller mf,ec,entropy --runs 5 --steps 2000 --interaction congratulation --budget 50
takeover|--controller mf,mb,ec,rnd --runs 5 --steps 2000 --interaction takeover --budget 50
punish|--task tidy2 --controller ec,mb --runs 4 --steps 2000 --interaction punishment --budget 40 --forget 0.3
nuisance|--controller ec,mf --runs 4 --steps 2000 --profile nuisance
rewardhuman|--controller ec,mb --runs 4 --steps 2000 --profile rewards-then-leaves
shaping|--controller ec,mf --runs 4 --steps 2000 --interaction congratulation --budget 100 --congratulation-effect reward --zeta 0.3
argmax|--controller ec,entropy,rnd --runs 4 --steps 2000 --selection argmax --window-n 3 --q-init 0.5
params|--controller ec --runs 4 --steps 2000 --gamma-mb 0.8 --tau 0.05 --filter-alpha 0.3 --kappa-coeff 2 --normalise-entropy off --checkpoint 7
boxes|--controller ec,mb --runs 4 --steps 3000 --boxes gbr --change 1500:boxes=brg --change 2000:interaction=takeover --change 2000:budget=20
stingy|--task tidy2 --controller ec --runs 4 --steps 2000 --profile stingy --babbling 50
nav|--task json:$NAV/realisticNavWorld.json --controller mf,mb,ec,rnd,entropy --runs 4 --steps 2500 --change 1601:goal=34
navdel|--task json:$NAV/realisticNavWorld.json --controller ec,mb --runs 4 --steps 2500 --change 1601:world=json:$NAV/realisticNavWorld_noTrans20-21.json
rules|--controller fixed,reliability,vpi --runs 4 --steps 2000 --interaction congratulation --budget 50
mix|--controller ec,fixed,reliability --combine mix --runs 4 --steps 2000 --change 1000:boxes=brg
mixsteady|--controller fixed,rnd,ec --combine mix --runs 6 --steps 4000 --w-mb 0.3
mixrel|--controller reliability,entropy,ec --combine mix --runs 6 --steps 4000 --babbling 300
mixtidy2|--task tidy2 --controller fixed,rnd,entropy --combine mix --runs 4 --steps 3000 --window-n 3
mixtwostep|--task twostep --controller fixed,rnd,reliability,entropy --combine mix --runs 6 --steps 2000 --tau 0.2 --lambda-mf 1
mixnav|--task json:$NAV/realisticNavWorld.json --controller fixed,reliability --combine mix --runs 4 --steps 2500
twostep|--task twostep --controller mf,mb,ec,fixed,reliability,vpi --runs 6 --steps 400
vpi|--controller vpi --runs 8 --steps 6000 --babbling 500
vpilong|--controller vpi --runs 48 --steps 20000 --tau 0.5
vpiparams|--task tidy2 --controller vpi --runs 6 --steps 3000 --vpi-tau 0.5 --kalman-noise 0.2 --kalman-v0 4 --rbar-rate 0.1 --interaction congratulation --budget 40
vpitwostep|--task twostep --controller vpi --runs 8 --steps 3000 --tau 0.2
vpinav|--task json:$NAV/realisticNavWorld.json --controller vpi --runs 4 --steps 2500 --change 1601:goal=34
EOF2
exit $fail
