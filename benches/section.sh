#!/usr/bin/env bash
# What a section costs and saves (docs/results.md, "Sections: cut and measure"): the
# demo plant (4M triangles, seed 1) along the demo's walk at 640x360, och
# at 1 px, with
#   none: no section;
#   all:  a plane beyond the model that keeps all of it (the pure cost:
#         the clipping pipelines and the per-node tests, nothing removed);
#   half: a plane through the middle of the model keeping x <= centre
#         (about half of it).
# On the best adapter here (`best`: lavapipe on a machine without a GPU) and on
# the null adapter (every GPU operation free: the CPU's share), each set
# run three times, interleaved (none, all, half, none, all, half, ...),
# since times on shared machines drift; prints one line a run (median
# frame ms, mean triangles, nodes dropped by the section a frame) and,
# per set, the median of its runs' ratios to the `none` run beside them.
#
# Usage: benches/section.sh [OUT_DIR] [--quick]   (--quick: 40 poses)
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/section-bench}"
quick=0
[ "${2:-}" = "--quick" ] && quick=1
bin="${GIGAWALK_BIN:-target/release/gigawalk}"
scenes="target/section-scenes"
[ -x "$bin" ] || cargo build --release -p gigawalk
mkdir -p "$out" "$scenes"
if [ ! -f "$scenes/plant4m.gwk" ]; then
  echo "== preparing the demo plant (4M triangles, seed 1, 200 poses)"
  "$bin" generate plant --triangles 4M --seed 1 --poses 200 \
    -o "$scenes/plant4m.glb" --path "$scenes/plant4m.path"
  "$bin" preprocess "$scenes/plant4m.glb" -o "$scenes/plant4m.gwk" >/dev/null
  rm -f "$scenes/plant4m.glb"
fi
frames=200
[ "$quick" = 1 ] && frames=40
scene="$scenes/plant4m.gwk"
# The model's x extent, from `gigawalk info`'s bounds line.
read -r x0 x1 < <("$bin" info "$scene" | sed -n 's/^bounds *\[\([^,]*\),.*\] \.\. \[\([^,]*\),.*/\1 \2/p')
mid=$(python3 -c "print(($x0 + $x1) / 2)")
beyond=$(python3 -c "print($x1 + 10 * ($x1 - $x0))")
echo "x from $x0 to $x1: half keeps x <= $mid, all keeps x <= $beyond"

run() { # ADAPTER SET REPEAT
  local adapter="$1" set="$2" rep="$3" dir="$out/$1-$2-$3"
  local args=() pick=()
  [ "$adapter" = null ] && pick=(--adapter null)
  case "$set" in
    all) args=(--section "-1 0 0 $beyond") ;;
    half) args=(--section "-1 0 0 $mid") ;;
  esac
  "$bin" replay "$scene" --path "$scenes/plant4m.path" --frames "$frames" \
    --modes och --pixel-error 1 --accuracy-every 0 "${pick[@]}" \
    --out "$dir" "${args[@]}" >/dev/null 2>"$dir.log" || { cat "$dir.log"; exit 1; }
  python3 - "$dir/summary.json" "$adapter" "$set" "$rep" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
m = s["modes"][0]
print(f"{sys.argv[2]:8} {sys.argv[3]:5} #{sys.argv[4]}  median {m['median_frame_ms']:8.3f} ms  "
      f"triangles {m['mean_triangles']:10.0f}  section-culled {m.get('mean_section_culled', 0):8.1f}")
PY
}

for adapter in best null; do
  for rep in 1 2 3; do
    for set in none all half; do
      run "$adapter" "$set" "$rep" | tee -a "$out/runs.txt"
    done
  done
done
python3 - "$out" <<'PY'
import json, sys, statistics
out = sys.argv[1]
for adapter in ["best", "null"]:
    fig = {}
    for st in ["none", "all", "half"]:
        ms, tris = [], []
        for rep in [1, 2, 3]:
            m = json.load(open(f"{out}/{adapter}-{st}-{rep}/summary.json"))["modes"][0]
            ms.append(m["median_frame_ms"]); tris.append(m["mean_triangles"])
        fig[st] = (statistics.median(ms), statistics.median(tris), ms)
    n = fig["none"]
    for st in ["all", "half"]:
        f = fig[st]
        ratios = [a / b for a, b in zip(f[2], n[2])]
        pairs = " ".join(f"{r:.3f}" for r in ratios)
        print(f"{adapter:8} {st:5} vs none: frame time {statistics.median(ratios):.3f}x (runs {pairs}), triangles {f[1] / n[1]:.3f}x")
PY
