#!/usr/bin/env bash
# Runs every shipped scenario (long ones shortened by --set) with the release build and prints
# one SHA-256 per result file, timing fields left out, so two builds can be compared bit for
# bit: `scripts/same_bits.sh DIR > a.txt`, change the code, run it again into another DIR,
# then `diff a.txt b.txt`. Writes only into DIR (created; must not exist). BIN=path runs that
# binary instead of building this tree.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:?usage: scripts/same_bits.sh OUTDIR}
[ -e "$dir" ] && { echo "$dir exists" >&2; exit 2; }
mkdir -p "$dir"
bin=${BIN:-target/release/hydrofrac}
[ -n "${BIN:-}" ] || cargo build --release --quiet
run() { # name, scenario, overrides...
    local name=$1 sc=$2; shift 2
    local args=()
    for s in "$@"; do args+=(--set "$s"); done
    "$bin" run "scenarios/$sc" --out "$dir/$name" --quiet "${args[@]}" >"$dir/$name.log" 2>&1 \
        || echo "$name: exit $?" >>"$dir/exits.txt"
}
run insitu insitu_stress.ron
run single flow_single_fracture.ron
run junction flow_junction.ron
run network flow_network.ron
run sneddon sneddon.ron
run inclined inclined_crack.ron
run kgd_toughness kgd_toughness.ron
run kgd_m kgd_m.ron 'time.end=Time(1.0)'
run kgd kgd.ron 'time.end=Time(0.4)'
run cross example1_cross.ron 'time.end=Time(0.25)'
run cross_qs example1_cross.ron 'time.end=Time(0.25)' 'time.solid_scheme=QuasiStatic'
run offset example1_offset.ron 'time.end=Time(0.25)'
run conf example1_cross_conforming.ron 'time.end=Time(0.02)'
run conf_qs example1_cross_conforming.ron 'time.end=Time(0.3)' 'time.solid_scheme=QuasiStatic'
run ex2_small example2_small.ron
run ex2 example2.ron 'time.end=Time(0.1)'
"$bin" pipeline scenarios/example1_reservoir.ron --out "$dir/pipeline" --quiet \
 >"$dir/pipeline.log" 2>&1 || echo "pipeline: exit $?" >>"$dir/exits.txt"
# Hash every result; in JSON drop the fields that hold wall-clock times.
cd "$dir"
find . -type f ! -name '*.log' ! -name 'timing.csv' ! -name '*.png' ! -name 'manifest*' | sort | while read -r f; do
    case "$f" in
    *production.csv) h=$(cut -d, -f1-10,12- "$f" | sha256sum | cut -c1-16) ;; # less wall_s
    *.json) h=$(jq -S 'walk(if type == "object" then with_entries(select(.key | test("wall|seconds|timing|elapsed|per_system|_s$|threads|version|commit|date|started") | not)) else . end)' "$f" | sha256sum | cut -c1-16) ;;
    *) h=$(sha256sum "$f" | cut -c1-16) ;;
    esac
    echo "$h $f"
done
[ -f exits.txt ] && cat exits.txt
exit 0
