#!/usr/bin/env bash
# Object identity's costs (docs/results.md, "Object identity"):
#   1. the OBJT section's bytes against the scene's, on the 10M plant, the
#      10M machine floor and the real CAD assemblies of ../shared/models
#      as one model (gigawalk info's `objects` line);
#   2. `gigawalk pick` on the 10M plant at 1280x720: the ray cast and the
#      leaves it reads (its `ms`, median of 20 pixels of the walk's middle
#      pose), and the whole command (opening the scene, reading the
#      object table) by wall clock;
#   3. what hiding costs (crates/replay/examples/hide_cost.rs): och at 1 px
#      with one object hidden and with 1% isolated, against everything
#      shown and against a scene of only that 1%, on the best adapter here
#      (lavapipe on a machine without a GPU).
# Scenes are generated and preprocessed once into target/objects-scenes.
#
# Usage: benches/objects.sh [--quick]   (--quick: 1M plant, 20 frames)
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[ "${1:-}" = "--quick" ] && quick=1
bin="${GIGAWALK_BIN:-target/release/gigawalk}"
scenes="target/objects-scenes"
[ -x "$bin" ] || cargo build --release -p gigawalk
cargo build --release -q -p gigawalk-replay --example hide_cost
mkdir -p "$scenes"

scene() {
  local name="$1" kind="$2" tris="$3" seed="$4"
  if [ ! -f "$scenes/$name.gwk" ]; then
    echo "== preparing $name ($kind, $tris triangles, seed $seed)"
    "$bin" generate "$kind" --triangles "$tris" --seed "$seed" --poses 200 \
      -o "$scenes/$name.glb" --path "$scenes/$name.path"
    "$bin" preprocess "$scenes/$name.glb" -o "$scenes/$name.gwk" >/dev/null
  fi
}

if [ "$quick" = 1 ]; then
  plant=plant1m; scene plant1m plant 1M 1; frames=20
  list=(plant1m)
else
  plant=plant10m; scene plant10m plant 10M 1; frames=60
  scene machine10m machine 10M 1
  list=(plant10m machine10m)
  if [ ! -f "$scenes/cad.gwk" ]; then
    echo "== preparing cad (the real CAD assemblies as one model)"
    "$bin" preprocess ../shared/models/*/*.glb -o "$scenes/cad.gwk" >/dev/null
  fi
  list+=(cad)
fi

echo "== 1. identity bytes"
for s in "${list[@]}"; do
  printf '%-12s %s\n' "$s" "$("$bin" info "$scenes/$s.gwk" | grep '^objects')"
done

echo "== 2. pick on $plant at 1280x720, 20 pixels of pose 100"
ms=()
wall=()
for y in 90 270 450 630; do
  for x in 128 384 640 896 1152; do
    t0=$(date +%s.%N)
    j=$("$bin" pick "$scenes/$plant.gwk" --path "$scenes/$plant.path" --frame 100 \
      --pixel "$x,$y" --width 1280 --height 720 --json)
    t1=$(date +%s.%N)
    ms+=("$(echo "$j" | python3 -c 'import json,sys; print(json.load(sys.stdin)["ms"])')")
    wall+=("$(python3 -c "print(($t1 - $t0) * 1e3)")")
  done
done
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print (a[int((NR+1)/2)] + a[int(NR/2)+1]) / 2}'; }
echo "pick ray cast + leaves read: median $(median "${ms[@]}") ms; whole command: median $(median "${wall[@]}") ms"

echo "== 3. hiding on $plant"
# As the gigawalk binary does without a desktop session: Mesa's Vulkan
# device-select layer would print an XDG_RUNTIME_DIR error per adapter
# enumeration.
[ -n "${XDG_RUNTIME_DIR:-}" ] || export NODEVICE_SELECT=1
target/release/examples/hide_cost "$scenes/$plant.glb" "$scenes/$plant.gwk" \
  "$scenes/$plant.path" --frames "$frames" --width 640 --height 360
