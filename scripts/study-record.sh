#!/usr/bin/env bash
# Keep a long sweep's results in the repository, so a study run in parts on machines that do
# not keep their disks (or on several machines) adds up to one table.
#
#   scripts/study-record.sh save    STUDY_DIR RECORD_DIR [COMMIT]
#       copies plan.json and, for every finished member (status "ok"), its status.json and
#       run/summary.json (what `hydrofrac sweep collect` reads) into RECORD_DIR; COMMIT, the
#       commit of the binary that ran them, is noted in RECORD_DIR/members.txt
#   scripts/study-record.sh restore RECORD_DIR STUDY_DIR
#       into a freshly planned STUDY_DIR (`hydrofrac sweep plan ... --out STUDY_DIR`) whose
#       plan.json is the record's to the byte, copies the recorded members back, so that
#       `hydrofrac sweep run` skips them and `hydrofrac sweep collect` tables them.
#
# `hydrofrac sweep collect RECORD_DIR` works on the record itself (it needs only plan.json,
# status.json and run/summary.json). A member's status.json holds the fingerprint of its
# resolved scenario: a record made for other scenario files is refused by the plan check here
# and its members count as not run for the sweep.
set -euo pipefail
cmd=${1:-}
case "$cmd" in
save)
    src=$2 dst=$3 commit=${4:-unknown}
    [ -f "$src/plan.json" ] || { echo "no plan.json in $src" >&2; exit 2; }
    mkdir -p "$dst"
    if [ -f "$dst/plan.json" ] && ! cmp -s "$src/plan.json" "$dst/plan.json"; then
        echo "$dst holds the record of another plan" >&2; exit 2
    fi
    cp "$src/plan.json" "$dst/plan.json"
    touch "$dst/members.txt"
    n=0
    for m in "$src"/members/*/; do
        id=$(basename "$m")
        [ -f "$m/status.json" ] && [ -f "$m/run/summary.json" ] || continue
        grep -q '"status": "ok"' "$m/status.json" || continue
        mkdir -p "$dst/members/$id/run"
        cp "$m/status.json" "$dst/members/$id/status.json"
        cp "$m/run/summary.json" "$dst/members/$id/run/summary.json"
        grep -q "^$id " "$dst/members.txt" || echo "$id $commit" >> "$dst/members.txt"
        n=$((n + 1))
    done
    sort -o "$dst/members.txt" "$dst/members.txt"
    echo "recorded $n finished members in $dst"
    ;;
restore)
    src=$2 dst=$3
    [ -f "$dst/plan.json" ] || { echo "plan the study into $dst first (hydrofrac sweep plan)" >&2; exit 2; }
    cmp -s "$src/plan.json" "$dst/plan.json" || { echo "$dst was planned from other files than the record in $src" >&2; exit 2; }
    n=0
    for m in "$src"/members/*/; do
        id=$(basename "$m")
        [ -d "$dst/members/$id" ] || { echo "member $id is not in the plan of $dst" >&2; exit 2; }
        mkdir -p "$dst/members/$id/run"
        cp "$m/status.json" "$dst/members/$id/status.json"
        cp "$m/run/summary.json" "$dst/members/$id/run/summary.json"
        n=$((n + 1))
    done
    echo "restored $n members into $dst"
    ;;
*)
    sed -n '2,20p' "$0" >&2; exit 2 ;;
esac
