#!/usr/bin/env bash
# The frame's fixed cost: what the CPU can feed a GPU, measured with the
# null adapter (`--adapter null`: every GPU operation free, nothing drawn,
# depth read back as zeros, so nothing is occluded and traversal and
# drawing do their most work). vfc, hlod and och (the HZB built on OR's
# device, the default) and och with `--hzb cpu` (the whole depth image read
# back and the pyramid built on the CPU), on the demo plant, a procedural
# machine floor and a large plant, at 640x360, 1920x1080 and 3840x2160.
# Every run draws all occluders (`--occluder-budget all`), so runs differ
# only in what is measured. Prints one line a run and writes each report under OUT_DIR
# (docs/results.md, "Frame cost on the CPU (null GPU)").
#
# Then what the read-back level costs in culling, on a real rasterizer
# (the best adapter here: lavapipe on a machine without a GPU): och's
# triangles with the HZB read at each level (cpu = the whole image, 1 to
# 4) at 640x360 and 1920x1080, in the same run.
#
# Usage: benches/cpu-ceiling.sh [OUT_DIR] [--quick]
#   --quick: the demo plant only, 40 poses (a minute or two)
# Scenes are generated and preprocessed once into target/cpu-ceiling-scenes
# (the 50M plant takes about 15 minutes on 2 cores; GIGAWALK_BIG=0 skips it).
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/cpu-ceiling}"
quick=0
[ "${2:-}" = "--quick" ] && quick=1
bin="${GIGAWALK_BIN:-target/release/gigawalk}"
scenes="target/cpu-ceiling-scenes"
[ -x "$bin" ] || cargo build --release -p gigawalk
mkdir -p "$out" "$scenes"

# scene NAME KIND TRIANGLES SEED: generates and preprocesses it once
# (the walk of 200 poses, as the demo's).
scene() {
  local name="$1" kind="$2" tris="$3" seed="$4"
  if [ ! -f "$scenes/$name.gwk" ]; then
    echo "== preparing $name ($kind, $tris triangles, seed $seed)"
    "$bin" generate "$kind" --triangles "$tris" --seed "$seed" --poses 200 \
      -o "$scenes/$name.glb" --path "$scenes/$name.path"
    "$bin" preprocess "$scenes/$name.glb" -o "$scenes/$name.gwk"
    rm -f "$scenes/$name.glb"
  fi
}

frames=100
list=(plant4m)
scene plant4m plant 4M 1
if [ "$quick" = 1 ]; then
  frames=40
else
  scene machine10m machine 10M 1
  list+=(machine10m)
  if [ "${GIGAWALK_BIG:-1}" != 0 ]; then
    scene plant50m plant 50M 1
    list+=(plant50m)
  fi
fi

# One line a run: scene, viewport, mode, fps, median ms, STC ms (HZB ms),
# OR ms, read-back KB a frame, HZB level.
summary() {
  python3 - "$1" "$2" "$3" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
for m in s["modes"]:
    c = m.get("cpu", {})
    name = m["name"] + (" " + sys.argv[3] if m["name"] == "och" and sys.argv[3] else "")
    print(f'{sys.argv[2]:<28} {name:<12} {m["mean_fps"]:8.1f} fps  median {m["median_frame_ms"]:6.2f} ms  '
          f'STC {m["median_stc_ms"]:6.2f} (HZB {m["median_hzb_ms"]:5.2f}, traversal {c.get("median_traversal_ms", 0):5.2f}, '
          f'tests {c.get("median_cull_test_ms", 0):5.2f})  OR {m["median_or_ms"]:6.2f}  '
          f'read back {c.get("mean_or_read_bytes", 0) / 1e3:8.1f} KB  level {c.get("median_hzb_level", 0):.0f}  '
          f'triangles {m["mean_triangles"]:10.0f}')
EOF
}

for s in "${list[@]}"; do
  for size in 640x360 1920x1080 3840x2160; do
    w="${size%x*}"; h="${size#*x}"
    for variant in gpu cpu; do
      if [ "$variant" = gpu ]; then modes=vfc,hlod,och; else modes=och; fi
      dir="$out/$s-$size-$variant"
      "$bin" replay "$scenes/$s.gwk" --path "$scenes/$s.path" --adapter null --occluder-budget all \
        --modes "$modes" --frames "$frames" --accuracy-every 0 \
        --width "$w" --height "$h" --hzb "$variant" --out "$dir" >"$dir.log" 2>&1 \
        || { echo "FAILED: $s $size $variant: $(grep '^error' "$dir.log" | tail -1)"; continue; }
      summary "$dir/summary.json" "$s $size" "$([ "$variant" = cpu ] && echo 'hzb cpu' || true)"
    done
  done
done

# Culling kept: och's triangles by the level read back, on a rasterizer.
levels() {
  python3 - "$1" "$2" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
m = s["modes"][0]
c = m.get("cpu", {})
print(f'{sys.argv[2]:<36} triangles {m["mean_triangles"]:10.0f}  occlusion-culled {m["mean_occlusion_culled"]:8.0f}  '
      f'read back {c.get("mean_or_read_bytes", 0) / 1e3:8.1f} KB  HZB {m["median_hzb_ms"]:5.2f} ms  STC {m["median_stc_ms"]:6.2f} ms')
EOF
}
for s in "${list[@]}"; do
  [ "$s" = plant50m ] && continue
  for size in 640x360 1920x1080; do
    w="${size%x*}"; h="${size#*x}"
    for level in cpu 1 2 3 4; do
      dir="$out/$s-$size-raster-$level"
      if [ "$level" = cpu ]; then hzb=(--hzb cpu); else hzb=(--hzb-level "$level"); fi
      "$bin" replay "$scenes/$s.gwk" --path "$scenes/$s.path" --modes och --occluder-budget all \
        --frames "$frames" --accuracy-every 0 --width "$w" --height "$h" "${hzb[@]}" \
        --out "$dir" >"$dir.log" 2>&1 \
        || { echo "FAILED: $s $size level $level: $(grep '^error' "$dir.log" | tail -1)"; continue; }
      levels "$dir/summary.json" "$s $size level $level"
    done
  done
done
