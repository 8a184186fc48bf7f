#!/usr/bin/env bash
# Does "pixel error p" hold, and what do HLODs buy, across scene kinds,
# seeds and sizes (docs/results.md, "Across scenes and
# viewports")? For every scene: generate, preprocess (cached in OUT_DIR), and
# replay hlod and och at pixel error 1 and 2 against the full-detail
# reference, at 640x360 and 1920x1080; prints one table row per run:
# bound-violating fraction, the same with the depth match scaled to the
# tolerance ("beyond the bound"), mean triangles, triangles per viewport
# pixel.
# Usage: benches/hlod-accuracy.sh [OUT_DIR] [SCENE...]
#   SCENE is KIND:TRIANGLES:SEED, default plant:1M:1 plant:1M:2 plant:2M:5
#   city:1M:1 forest:1M:1 (about 25 minutes on 2 cores with lavapipe).
# FRAMES (default 60) and EVERY (accuracy every Nth frame, default 10)
# size the replays.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/hlod-accuracy}"
shift || true
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(plant:1M:1 plant:1M:2 plant:2M:5 city:1M:1 forest:1M:1)
frames="${FRAMES:-60}"
every="${EVERY:-10}"
bin="${GIGAWALK_BIN:-target/release/gigawalk}"
[ -x "$bin" ] || cargo build --release -p gigawalk
mkdir -p "$out"
status=0
echo "| scene | viewport | mode | pixel error | bound-violating px | beyond the bound px | mean triangles | triangles per pixel |"
echo "|---|---|---|---:|---:|---:|---:|---:|"
for s in "${scenes[@]}"; do
  IFS=: read -r kind tris seed <<<"$s"
  base="$out/$kind-$tris-seed$seed"
  if [ ! -f "$base.gwk" ]; then
    "$bin" generate "$kind" --triangles "$tris" --seed "$seed" -o "$base.glb" --path "$base.path" \
      >"$base.gen.log" 2>&1 &&
      "$bin" preprocess "$base.glb" -o "$base.gwk" --stats "$base.stats.json" >"$base.pre.log" 2>&1 ||
      { echo "| $s | FAILED to build, see $base.*.log | | | | | | |"; status=1; continue; }
  fi
  for vp in 640x360 1920x1080; do
    w="${vp%x*}"; h="${vp#*x}"
    rep="$base-$vp"
    if ! "$bin" replay "$base.gwk" --path "$base.path" --out "$rep" --modes hlod,och \
      --pixel-error 1,2 --frames "$frames" --accuracy-every "$every" --width "$w" --height "$h" \
      >"$rep.log" 2>&1; then
      echo "| $s | $vp | FAILED: $(grep '^error' "$rep.log" | tail -1) | | | | | |"
      status=1
      continue
    fi
    python3 - "$rep/summary.json" "$s" "$vp" "$((w * h))" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
def pct(m, key):
    f = m.get(key)
    return "n/a" if f is None else f"{100 * f:.3f}%"
for m in d["modes"]:
    v, x = pct(m, "bound_violating_fraction"), pct(m, "bound_exceeding_fraction")
    t = m["mean_triangles"]
    print(f"| {sys.argv[2]} | {sys.argv[3]} | {m['name']} | {m['pixel_error']:g} | {v} | {x} | {t:,.0f} | {t / int(sys.argv[4]):.2f} |")
EOF
  done
done
exit $status
