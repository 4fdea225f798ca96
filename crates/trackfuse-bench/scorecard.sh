#!/usr/bin/env bash
# Issue 13's speed figures on this machine, in one window (BENCHMARKS.md, "Speed to the
# hardware (issue 13)", "Where each point stands"):
#
#   crates/trackfuse-bench/scorecard.sh OUT
#
# OUT: a new folder for the simulated data and the outputs (about 1.5 GB; refused if it
# exists). Environment: TRACKFUSE (default target/release/trackfuse of this repo; build
# it first with `cargo build --release -p trackfuse-cli`), ROUNDS (default 3).
#
# Prints labelled lines, one section per point of the issue, the small timings first
# (each section after a `sync`, so that no write-back of the last one runs beside it):
# - point 4: `track` + `fuse --rule ci --bias none` on the 100-target grid (track-bench
#   at 100 scans, the default `score` initiation), a wall clock around both processes
#   (Stone Soup on the same files: `stonesoup/paired.sh`, which takes minutes);
# - point 6: `mc --runs 100` of every paper scenario: wall, CPU and peak memory;
# - point 2: `bench track-sweep` (radars, then position sensors) and `bench fuse --sweep`;
# - point 3: `track` and `fuse` at 1 and 2 threads on grid-bench's 100 scans;
# - point 1: `bench io` (MB/s per core, reading and writing), and the wall, CPU and peak
#   resident memory of `track` and `fuse` at 100 and 1 000 scans of grid-bench.
# Point 5 is a criterion benchmark: `cargo bench -p trackfuse-bench --bench ci_rule`.
# Timings move with whatever else the machine runs: run it on a quiet machine, and
# compare figures of one run only.
set -euo pipefail

if [ $# -ne 1 ]; then
    echo "usage: $0 OUT" >&2
    exit 2
fi
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
TF=${TRACKFUSE:-$REPO/target/release/trackfuse}
ROUNDS=${ROUNDS:-3}
SCEN=$REPO/scenarios
if [ ! -x "$TF" ]; then
    echo "$0: no trackfuse binary at $TF (cargo build --release -p trackfuse-cli)" >&2
    exit 2
fi
if [ ! -x /usr/bin/time ]; then
    echo "$0: needs GNU time at /usr/bin/time (Debian, Ubuntu: apt install time)" >&2
    exit 2
fi
if [ -e "$1" ]; then
    echo "$0: $1 exists; give a new folder" >&2
    exit 2
fi
mkdir -p "$1"
cd "$1"

# `wall user sys max-resident-KiB` of one command, its output discarded
timed() { /usr/bin/time -f "%e %U %S %M" "$@" 2>&1 >/dev/null | tail -1; }
now() { date +%s.%N; }
# let the kernel write back what the previous section wrote (gigabytes at 1 000 scans)
# before timing the next one
settle() {
    sync
    sleep 2
}

echo "start $(date -u +%FT%TZ), load average $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores"
sed "s/^scans = 1000/scans = 100/" "$SCEN/grid-bench.toml" >grid-100.toml
cp "$SCEN/grid-bench.toml" grid-1000.toml
sed -e "s/^scans = 200/scans = 100/" -e '/^\[tracker.initiation\]/,/^n = 5/d' \
    "$SCEN/track-bench.toml" >tb100-score.toml
for n in 100 1000; do
    "$TF" simulate "grid-$n.toml" --out "sim-$n" >/dev/null 2>&1
    "$TF" track --data "sim-$n" --out "track-$n" >/dev/null 2>&1
done
"$TF" simulate tb100-score.toml --out tb >/dev/null 2>&1

settle
echo "== point 4: track + fuse --rule ci --bias none on the 100-target grid (wall s)"
for r in $(seq $((ROUNDS + 2))); do
    t0=$(now)
    "$TF" track --data tb --scenario tb100-score.toml --out "t4-$r" >/dev/null 2>&1
    "$TF" fuse --local-tracks "t4-$r/local_tracks.csv" --rule ci --bias none --out "f4-$r" >/dev/null 2>&1
    t1=$(now)
    echo "pipeline: $(echo "$t0 $t1" | awk '{printf "%.3f", $2 - $1}')"
done

settle
echo "== point 6: mc --runs 100 (wall s, user s, sys s, max RSS KiB)"
for r in $(seq "$ROUNDS"); do
    for s in 000-s1 000-s2 000-s3 001-s1 001-s2 002-s1 003-case1 003-case2 004-case1 004-case2; do
        echo "mc $s: $(timed "$TF" mc "$SCEN/$s.toml" --runs 100 --quiet --out "mc-$r-$s")"
    done
done

settle
echo "== point 2: bench track-sweep, radars (series B)"
"$TF" bench track-sweep --repeat "$ROUNDS" 2>&1 | grep "^|"
echo "== point 2: bench track-sweep --sensors position (series C)"
"$TF" bench track-sweep --sensors position --repeat "$ROUNDS" 2>&1 | grep "^|"
echo "== point 2: bench fuse --threads 1 --rule cc --sweep (the fusion center)"
for _ in $(seq "$ROUNDS"); do
    "$TF" bench fuse --threads 1 --rule cc --sweep 400,4000,12000,40000,120000 2>&1 | grep -v "^$"
done
settle
echo "== point 3: threads (wall s, user s, sys s, max RSS KiB)"
for r in $(seq "$ROUNDS"); do
    for t in 1 2; do
        echo "track --threads $t: $(timed "$TF" --threads "$t" track --data sim-100 --out "t3-$r-$t")"
        echo "fuse --threads $t: $(timed "$TF" --threads "$t" fuse --local-tracks track-100/local_tracks.csv --bias none --out "f3-$r-$t")"
    done
done

settle
echo "== point 1: bench io (MB/s per core)"
for _ in $(seq "$ROUNDS"); do
    "$TF" bench io --data sim-100 --local-tracks track-100/local_tracks.csv 2>&1 | grep -i "MB/s"
done
echo "== point 1: peak memory against the number of scans (wall s, user s, sys s, max RSS KiB)"
for n in 100 1000; do
    echo "track $n scans: $(timed "$TF" track --data "sim-$n" --out "t1-$n")"
    echo "fuse $n scans: $(timed "$TF" fuse --local-tracks "track-$n/local_tracks.csv" --bias none --out "f1-$n")"
done

echo "end $(date -u +%FT%TZ), load average $(cut -d' ' -f1-3 /proc/loadavg)"
