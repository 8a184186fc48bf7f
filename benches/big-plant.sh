#!/usr/bin/env bash
# A plant too big for one machine's memory, end to end: generate it (in
# several .glb files: one holds at most 4 GiB), preprocess it under the
# default memory budget with --stats (in one process; RESUMABLE=1 splits
# it in shards kept under OUT, so that a run stopped part way resumes when
# the script runs again), then the viewer's first frame at
# --memory-budget 1G under Xvfb.
#
#   SIZE=500M SEED=3 RESUMABLE=0 benches/big-plant.sh [OUT]
#
# SIZE defaults to 500M, SEED to 3, OUT to target/big-plant (it needs
# about 8 GB for the model, 22 GB of spill and 6 GB for the scene at
# 500M). Prints the wall time, CPU and peak memory of each step; the logs
# and the stats JSON stay in OUT.
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${SIZE:-500M}
SEED=${SEED:-3}
OUT=${1:-target/big-plant}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
cargo build --release -p gigawalk
G=$OUT/gigawalk
cp target/release/gigawalk "$G"

model="$OUT/plant-$SIZE-seed$SEED"
triangles=$(python3 -c "
s = '$SIZE'; m = {'k': 1e3, 'K': 1e3, 'm': 1e6, 'M': 1e6}
print(int(float(s[:-1]) * m[s[-1]]) if s[-1] in m else int(s))")
# About 15 bytes a triangle: files of at most 2.5 GB.
parts=$(((triangles + 149999999) / 150000000))
timed() {
  local name=$1
  shift
  /usr/bin/time -f "$name: %e s wall, %U s user, %S s system, %M KB peak" "$@" \
    >"$OUT/$name.log" 2>&1 || { tail -5 "$OUT/$name.log"; exit 1; }
  tail -1 "$OUT/$name.log"
}
if [ ! -f "$model.path" ]; then
  mkdir -p "$model"
  timed generate "$G" generate plant --triangles "$SIZE" --seed "$SEED" \
    --parts "$parts" -o "$model/plant.glb" --path "$model.path"
fi
split=()
[ "${RESUMABLE:-0}" = 1 ] && split=(--work-dir "$OUT/work")
[ -f "$model.gwk" ] ||
  timed preprocess "$G" preprocess "$model" -o "$model.gwk" --stats "$OUT/stats.json" "${split[@]}"
rm -rf "$OUT/work"
# Split builds (RESUMABLE=1) time only the merge in their stats: the
# rate is the run's triangles over its wall time.
python3 - "$OUT/stats.json" "$OUT/preprocess.log" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
wall = float(open(sys.argv[2]).read().strip().splitlines()[-1].split()[1])
print("phases:", ", ".join(f"{p} {t:.1f} s" for p, t in s["phase_seconds"]))
print(f"{s['triangles']} triangles in {wall:.1f} s, {s['triangles'] / wall:.0f} triangles/s,"
      f" scene {s['output_bytes'] / 1e9:.2f} GB")
EOF

# The viewer's first frame, streaming at 1G.
if command -v Xvfb >/dev/null; then
  fd="$OUT/xvfb.display"
  Xvfb -displayfd 9 -screen 0 1280x720x24 -nolisten tcp -noreset 9>"$fd" 2>"$OUT/xvfb.log" &
  xvfb=$!
  n=""
  for _ in $(seq 50); do n=$(cat "$fd" 2>/dev/null); [ -n "$n" ] && break; sleep 0.2; done
  if [ -n "$n" ]; then
    DISPLAY=":$n" timed first-frame env -u WAYLAND_DISPLAY "$G" view "$model.gwk" \
      --path "$model.path" --frames 1 --screenshot "$OUT/first-frame.png" --memory-budget 1G
  else
    echo "first frame: Xvfb did not start ($OUT/xvfb.log)"
  fi
  kill "$xvfb" 2>/dev/null || true
else
  echo "first frame: no Xvfb"
fi
