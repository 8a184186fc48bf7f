#!/usr/bin/env bash
# Preprocess speed, back to back: this checkout's build against another
# revision's, interleaved (base, new, new, base, ...) on the same generated
# plants, so both see the same box; the scenes are compared with cmp
# (a pure speed change leaves them byte-identical; where they differ,
# benches/scene-diff.py says in which sections).
#
#   BASE=<rev> SIZES="10M 20M" ROUNDS=2 benches/preprocess-speed.sh [OUT]
#   BASE=flags BASE_FLAGS="--gaps off" MODELS=floor.glb ROUNDS=2 benches/preprocess-speed.sh
#
# BASE defaults to origin/main's merge base with HEAD (BASE=none: no base
# run; BASE=flags: the base is this checkout's build run with BASE_FLAGS,
# a knob's cost), SIZES to 10M, ROUNDS to 1, OUT to target/preprocess-speed;
# MODELS (.glb files) replaces the generated plants. Prints one
# line per run (wall, CPU, peak memory, the HLOD phase's cores busy and
# its predicted speed-up on 16 cores from --stats) and writes each run's
# log and stats JSON under OUT. Needs python3 for the summary.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-target/preprocess-speed}
SIZES=${SIZES:-10M}
ROUNDS=${ROUNDS:-1}
SEED=${SEED:-3}
BASE=${BASE:-$(git merge-base HEAD origin/main 2>/dev/null || true)}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)

cargo build --release -p gigawalk
cp target/release/gigawalk "$OUT/gw-new"
builds=(new)
BASE_FLAGS=${BASE_FLAGS:-}
if [ "$BASE" = flags ]; then
  cp "$OUT/gw-new" "$OUT/gw-base"
  builds=(base new)
elif [ -n "$BASE" ] && [ "$BASE" != none ] && [ "$(git rev-parse "$BASE")" != "$(git rev-parse HEAD)" ]; then
  rm -rf "$OUT/base-src"
  git worktree prune
  git worktree add --detach "$OUT/base-src" "$BASE"
  CARGO_TARGET_DIR="$OUT/base-target" cargo build --release -p gigawalk \
    --manifest-path "$OUT/base-src/Cargo.toml"
  cp "$OUT/base-target/release/gigawalk" "$OUT/gw-base"
  git worktree remove --force "$OUT/base-src"
  builds=(base new)
fi

summary() {
  python3 - "$1" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
cores = dict((p, c) for p, c in s.get("phase_cores", []))
phase = dict((p, t) for p, t in s["phase_seconds"])
w = s.get("schedule") or {}
up = dict((n, x) for n, x in w.get("speedup", []))
run = dict((n, x) for n, x in w.get("run_speedup", []))
print(f"hlod {phase.get('hlod', 0):.1f} s at {cores.get('hlod', float('nan')):.2f} cores,"
      f" {s['triangles_per_second']:.0f} triangles/s,"
      f" 16 cores: hlod {up.get(16, float('nan')):.1f}x, run {run.get(16, float('nan')):.1f}x")
EOF
}

models=()
for size in $SIZES; do
  models+=("$OUT/plant-$size-seed$SEED.glb")
  [ -n "${MODELS:-}" ] || [ -f "${models[-1]}" ] ||
    "$OUT/gw-new" generate plant --triangles "$size" --seed "$SEED" -o "${models[-1]}"
done
[ -z "${MODELS:-}" ] || read -r -a models <<< "$MODELS"
for model in "${models[@]}"; do
  size=$(basename "$model" .glb)
  for round in $(seq 1 "$ROUNDS"); do
    order=("${builds[@]}")
    if [ $((round % 2)) -eq 0 ]; then
      order=($(printf '%s\n' "${builds[@]}" | tac))
    fi
    for b in "${order[@]}"; do
      tag="$size-$b-$round"
      flags=()
      [ "$b" = base ] && [ "$BASE" = flags ] && read -r -a flags <<< "$BASE_FLAGS"
      /usr/bin/time -f "%e s wall, %U s user, %M KB peak" \
        "$OUT/gw-$b" preprocess "$model" -o "$OUT/$tag.gwk" --stats "$OUT/$tag.json" "${flags[@]}" \
        > "$OUT/$tag.log" 2>&1
      echo "$tag: $(tail -1 "$OUT/$tag.log"); $(summary "$OUT/$tag.json")"
    done
    if [ "${#builds[@]}" -eq 2 ]; then
      if cmp -s "$OUT/$size-base-$round.gwk" "$OUT/$size-new-$round.gwk"; then
        echo "$size round $round: scenes byte-identical"
      else
        echo "$size round $round: scenes differ:"
        python3 benches/scene-diff.py "$OUT/$size-base-$round.gwk" "$OUT/$size-new-$round.gwk" \
          | sed 's/^/  /' || true
      fi
    fi
    rm -f "$OUT"/"$size"-*-"$round".gwk
  done
done
