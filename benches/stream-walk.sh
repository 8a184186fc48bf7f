#!/usr/bin/env bash
# Streaming walks of two (binary, scene) pairs, one after the other at each
# memory budget: stand-ins, frames with stand-ins, bytes loaded, peak
# resident bytes and median fps of och at 1 px, from replay's frames.csv.
# Used to compare device layouts: an older build on the scene it wrote
# against this build on its own (same model, same walk, same run).
#
#   benches/stream-walk.sh BIN_A SCENE_A BIN_B SCENE_B PATH [FRAMES] [BUDGETS...]
#
# e.g. benches/stream-walk.sh old/gigawalk p10_r12.gwk target/release/gigawalk \
#        p10.gwk p10.path 60 256M 64M 32M
set -euo pipefail
[ $# -ge 5 ] || { sed -n 2,11p "$0"; exit 2; }
bin_a=$1 scene_a=$2 bin_b=$3 scene_b=$4 path=$5
frames=${6:-60}
shift $(($# < 6 ? $# : 6))
budgets=("${@:-256M}")
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for budget in "${budgets[@]}"; do
  for side in A B; do
    if [ $side = A ]; then bin=$bin_a scene=$scene_a; else bin=$bin_b scene=$scene_b; fi
    dir=$out/$side-$budget
    "$bin" replay "$scene" --path "$path" --frames "$frames" --modes och \
      --accuracy-every 0 --width 640 --height 360 --memory-budget "$budget" \
      --out "$dir" > "$dir.log" 2>&1 || { cat "$dir.log" >&2; exit 1; }
    python3 - "$dir/frames.csv" "$side" "$budget" <<'PY'
import csv, statistics, sys
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r['mode'] == 'och']
sub = [int(r['substituted_draws']) for r in rows]
fps = [float(r['fps']) for r in rows if r['fps']]
peak = max(int(r['resident_bytes']) for r in rows)
loaded = sum(int(r['loaded_bytes']) for r in rows)
print(f"{sys.argv[2]} {sys.argv[3]:>5}: {len(rows)} frames, stand-ins {sum(sub)} "
      f"(frames 0-4: {sum(sub[:5])}, 5 on: {sum(sub[5:])}), frames with stand-ins "
      f"{sum(1 for s in sub if s)} (5 on: {sum(1 for s in sub[5:] if s)}), loaded "
      f"{loaded / 1e6:.1f} MB, peak resident {peak / 2**20:.1f} MiB, missing draws "
      f"{sum(int(r['missing_draws']) for r in rows)}, median fps {statistics.median(fps):.2f}")
PY
  done
done
