#!/usr/bin/env bash
# Paired speed measurement of the whole pipeline, trackfuse against Stone Soup, on the
# same files (issue 13, point 4).
#
#   crates/trackfuse-bench/stonesoup/paired.sh DATA OUT [SCENARIO]
#
# DATA: a folder with sensors.csv, measurements.csv, truth.csv (FORMATS.md), e.g. the
# output of `trackfuse simulate`. SCENARIO: the scenario whose [tracker] section
# `trackfuse track` uses (default: DATA/scenario.toml when present).
# Environment: TRACKFUSE (default target/release/trackfuse of this repo), STONESOUP_PYTHON
# (a Python with stonesoup and scipy installed, e.g. a virtual environment made with
# `python3 -m venv ss && ss/bin/pip install stonesoup`; default python3), STONESOUP_ARGS
# (extra options for grid_pipeline.py).
#
# It runs `trackfuse track` + `trackfuse fuse --rule ci --bias none`, then
# grid_pipeline.py, each timed as a wall clock around the whole process (start-up, CSV
# reading and writing included on both sides), prints one table with the ratio, and scores
# both fused outputs with `trackfuse evaluate` (GOSPA c = 500, p = 1).
set -euo pipefail

if [ $# -lt 2 ] || [ $# -gt 3 ]; then
    echo "usage: $0 DATA OUT [SCENARIO]" >&2
    exit 2
fi
DATA=$1
OUT=$2
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(cd "$HERE/../../.." && pwd)
TF=${TRACKFUSE:-$REPO/target/release/trackfuse}
STONESOUP_PYTHON=${STONESOUP_PYTHON:-python3}
SCEN=${3:-}
if [ -z "$SCEN" ] && [ -f "$DATA/scenario.toml" ]; then SCEN=$DATA/scenario.toml; fi
SCEN_ARGS=()
if [ -n "$SCEN" ]; then SCEN_ARGS=(--scenario "$SCEN"); fi

mkdir -p "$OUT"
now() { date +%s.%N; }

echo "== trackfuse track" >&2
t0=$(now)
"$TF" track --data "$DATA" "${SCEN_ARGS[@]}" --out "$OUT/tf-track" >&2
t1=$(now)
echo "== trackfuse fuse" >&2
"$TF" fuse --local-tracks "$OUT/tf-track/local_tracks.csv" --sensors "$DATA/sensors.csv" \
    --rule ci --bias none --out "$OUT/tf-fuse" >&2
t2=$(now)

echo "== Stone Soup ($STONESOUP_PYTHON)" >&2
t3=$(now)
# shellcheck disable=SC2086
"$STONESOUP_PYTHON" "$HERE/grid_pipeline.py" "$DATA" --out "$OUT/ss" ${STONESOUP_ARGS:-} \
    | tee "$OUT/ss-stdout.txt" >&2
t4=$(now)

echo "== evaluate" >&2
"$TF" evaluate --truth "$DATA/truth.csv" --tracks "$OUT/tf-fuse/fused_tracks.csv" \
    --gospa-c 500 --gospa-p 1 --out "$OUT/tf-eval" >&2
"$TF" evaluate --truth "$DATA/truth.csv" --tracks "$OUT/ss/fused_tracks.csv" \
    --gospa-c 500 --gospa-p 1 --out "$OUT/ss-eval" >&2

python3 - "$OUT" "$t0" "$t1" "$t2" "$t3" "$t4" <<'EOF' | tee "$OUT/table.md"
import json, sys
out = sys.argv[1]
t0, t1, t2, t3, t4 = map(float, sys.argv[2:])
ss = {}
for line in open(f"{out}/ss-stdout.txt"):
    if line.startswith("TIMES "):
        ss = json.loads(line[6:])
tf_track, tf_fuse, tf_total = t1 - t0, t2 - t1, t2 - t0
ss_wall = t4 - t3
print("| | trackfuse | Stone Soup %s | ratio (Stone Soup / trackfuse) |" % ss.get("stonesoup", "?"))
print("|---|---:|---:|---:|")
print(f"| local tracking (s) | {tf_track:.3f} | {ss.get('local', float('nan')):.3f} | "
      f"{ss.get('local', float('nan')) / tf_track:.0f} |")
print(f"| fusion (s) | {tf_fuse:.3f} | {ss.get('fusion', float('nan')):.3f} | "
      f"{ss.get('fusion', float('nan')) / tf_fuse:.0f} |")
print(f"| whole, process wall (s) | {tf_total:.3f} | {ss_wall:.3f} | {ss_wall / tf_total:.0f} |")
print()
print("trackfuse: process walls of `track` and `fuse`. Stone Soup: local and fusion from "
      "perf_counter inside the script (no start-up, no CSV I/O); its process wall includes "
      f"start-up + imports ({ss.get('imports', float('nan')):.2f} s), reading "
      f"({ss.get('read', float('nan')):.2f} s) and writing ({ss.get('write', float('nan')):.2f} s); "
      f"in-process total (read + local + fusion + write) {ss.get('total', float('nan')):.3f} s.")
print()
print("| fused output (GOSPA c=500, p=1) | GOSPA | localisation | missed | false | "
      "missed targets/scan | false tracks/scan | RMSE (m) | coverage |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
for name, d in (("trackfuse", "tf-eval"), ("Stone Soup", "ss-eval")):
    s = json.load(open(f"{out}/{d}/summary.json"))
    g = s["gospa"]
    print(f"| {name} | {g['mean']:.1f} | {g['localisation']:.1f} | {g['missed']:.1f} | "
          f"{g['false']:.1f} | {g['mean_missed_targets']:.2f} | {g['mean_false_tracks']:.2f} | "
          f"{s['fused_rmse']:.2f} | {s['track_coverage']:.3f} |")
EOF
