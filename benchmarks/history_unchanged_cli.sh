#!/bin/sh
# Issue 26, finding 1, on the command line: PAIRS pairs of calibrations of one machine
# that did not change (the same error table, other noise and set-up), 6 increments,
# 2 runs, compared by `volcal history compare` at the 5 % family-wise level.
#   sh benchmarks/history_unchanged_cli.sh [PAIRS] [VOLCAL]
set -e
PAIRS=${1:-10}
VOLCAL=${2:-volcal}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
$VOLCAL plan -o "$T/P" --steps 6 --runs 2 >/dev/null
flagged=0
k=0
while [ "$k" -lt "$PAIRS" ]; do
    # the machine's error table: the truth of a first simulation (seed 500 + k)
    cp -r "$T/P" "$T/M$k" && $VOLCAL simulate "$T/M$k" --seed $((500 + k)) >/dev/null
    db="$T/h$k.sqlite"
    for i in 1 2; do
        S="$T/S$k-$i"
        cp -r "$T/P" "$S"
        $VOLCAL simulate "$S" --seed $((1000 + 10 * k + i)) \
            --machine "$T/M$k/truth/machine.csv" >/dev/null
        $VOLCAL identify "$S" -o "$S/model.json" >/dev/null 2>&1
        $VOLCAL history add "$S" --model "$S/model.json" --db "$db" >/dev/null 2>&1 \
            || $VOLCAL history add "$S" --model "$S/model.json" --db "$db" --create >/dev/null
    done
    ids=$($VOLCAL history list --json --db "$db" | python3 -c \
        'import json,sys; print(" ".join(r["id"] for r in json.load(sys.stdin)))')
    out=$($VOLCAL history compare $ids --db "$db")
    if echo "$out" | grep -q CHANGED; then
        flagged=$((flagged + 1)); echo "pair $k:"; echo "$out" | grep CHANGED
    fi
    k=$((k + 1))
done
echo "$flagged of $PAIRS unchanged pairs flagged (family-wise level 5 %)"
