#!/usr/bin/env bash
# Speed and image error (differing, wrongly culled and bound-violating
# pixels) of every runtime knob on the default demo scene,
# each knob against the defaults in the same run (docs/results.md,
# "Runtime knobs"). Run `gigawalk demo` once first to build the cached scene.
# Usage: benches/knob-sweep.sh [OUT_DIR]   (about 6 minutes on 2 cores with lavapipe)
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/knob-sweep}"
bin="${GIGAWALK_BIN:-target/release/gigawalk}"
scene="target/gigawalk-demo-cache/plant-4000000-seed1-200poses"
[ -x "$bin" ] || cargo build --release -p gigawalk
[ -f "$scene.gwk" ] || "$bin" demo --out "$out/demo"
run() {
  local name="$1"; shift
  echo "== $name: $*"
  local log="$out/$name.log"
  mkdir -p "$out"
  if "$bin" replay "$scene.gwk" --path "$scene.path" --out "$out/$name" "$@" >"$log" 2>&1; then
    # The replay's table, header included so the columns can be told
    # apart: "bound-violating px" (pixels breaking the pixel-error bound,
    # docs/report-format.md) is the image error to compare knobs by.
    grep -E '^\| (mode|vfc|hlod|occ|och) ' "$log" || echo "(no table rows in $log)"
  else
    echo "FAILED: $(grep '^error' "$log" | tail -1)"
    status=1
  fi
}
status=0
run defaults --modes vfc,hlod,occ,och
run pixel-error --modes hlod,och --pixel-error 0,0.5,2,4,8
run occluder-scale-0.5 --modes occ,och --occluder-scale 0.5
run occluder-scale-0.25 --modes occ,och --occluder-scale 0.25
run nth-farthest-2 --modes occ,och --nth-farthest 2
run nth-farthest-3 --modes occ,och --nth-farthest 3
run occluder-lag-1 --modes occ,och --occluder-lag 1
run async --modes occ,och --async
run occluders-30k --modes occ,och --occluder-budget 30k
exit $status
