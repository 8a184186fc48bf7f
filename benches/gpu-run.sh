#!/usr/bin/env bash
# One unattended run on a real GPU, started with one command:
# builds release, prepares the default demo plant (4M triangles) and a
# 50M-triangle plant (both cached between runs), replays each at 1920x1080
# and 640x360 in the four modes with accuracy, times pipelined against
# sequential schedules, takes a viewer screenshot when a display (or Xvfb)
# is there, and writes OUTDIR/results.json (adapters, every figure with its
# unit) and OUTDIR/summary.md. Every step has a time limit and the whole
# run a deadline (8 minutes on a 16-core machine with an H200-class GPU);
# a failed or stopped step is recorded and the rest still run.
# docs/results.md ("Real GPU") says what it runs and what it writes.
#
# Usage: benches/gpu-run.sh OUTDIR [--quick]
#   --quick  small scenes, short paths, small viewports: a few minutes on
#            lavapipe (CI runs it: tools/gigawalk/tests/gpu_run.rs)
# Environment:
#   GIGAWALK_BIN             a built gigawalk binary: no cargo build
#   GIGAWALK_GPU_RUN_CACHE   prepared scenes (default target/gigawalk-gpu-run-cache)
#   GIGAWALK_GPU_RUN_BUDGET  seconds for the whole run (default 450; quick 600)
# Needs bash 4+, coreutils and, unless GIGAWALK_BIN is given, a Rust
# toolchain with every crate already downloaded (`cargo fetch` while online;
# the build tries --offline first, then online).
set -uo pipefail
cd "$(dirname "$0")/.." || exit 2
repo=$(pwd)

usage() { echo "usage: benches/gpu-run.sh OUTDIR [--quick]" >&2; exit 2; }
out="" quick=0
for a in "$@"; do
  case "$a" in
    --quick) quick=1 ;;
    -h|--help) usage ;;
    -*) echo "unknown option $a" >&2; usage ;;
    *) [ -z "$out" ] || usage; out="$a" ;;
  esac
done
[ -n "$out" ] || usage
mkdir -p "$out/logs" || exit 2
out=$(cd "$out" && pwd)
: >"$out/steps.tsv"
: >"$out/run.tsv"

# Milliseconds since the epoch (bash 5's EPOCHREALTIME, else date).
now_ms() {
  if [ -n "${EPOCHREALTIME:-}" ]; then
    local t=${EPOCHREALTIME//[.,]/}
    echo $((10#$t / 1000))
  else
    date +%s%3N
  fi
}
secs() { printf '%d.%03d' $(($1 / 1000)) $(($1 % 1000)); }
t0=$(now_ms)
elapsed() { secs $(($(now_ms) - t0)); }

if [ $quick = 1 ]; then
  budget=${GIGAWALK_GPU_RUN_BUDGET:-600}
  demo_tri=150000 big_tri=400000 poses=24 big_poses=24 stream_budget=2M
  hi=320x180 lo=160x90 every=4 shot_frames=8 pipe_frames=24
else
  budget=${GIGAWALK_GPU_RUN_BUDGET:-450}
  demo_tri=4000000 big_tri=50000000 poses=200 big_poses=200 stream_budget=1G
  hi=1920x1080 lo=640x360 every=10 shot_frames=60 pipe_frames=200
fi
deadline=$((t0 + budget * 1000))
cache=${GIGAWALK_GPU_RUN_CACHE:-$repo/target/gigawalk-gpu-run-cache}
mkdir -p "$cache"
target_dir=${CARGO_TARGET_DIR:-$repo/target}
bin=${GIGAWALK_BIN:-$target_dir/release/gigawalk}

# A field of steps.tsv: no tabs or newlines.
field() { local s=${1//$'\t'/ }; printf '%s' "${s//$'\n'/ }"; }
record() { # name kind status seconds limit output note
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$(field "$1")" "$2" "$3" "$4" "$5" \
    "$(field "$6")" "$(field "$7")" >>"$out/steps.tsv"
  echo "[$(elapsed)s]    $1: $3 in $4 s${7:+ ($7)}"
}
skip() { record "$1" "$2" skipped 0 0 "" "$3"; }

# run_step NAME KIND LIMIT_S OUTPUT CMD...: runs CMD under `timeout`
# (SIGINT first: a replay then writes the frames it measured; SIGKILL 15 s
# later), never past the run's deadline; the log is logs/NAME.log.
run_step() {
  local name=$1 kind=$2 limit=$3 output=$4
  shift 4
  local left=$(((deadline - $(now_ms)) / 1000))
  [ "$limit" -le "$left" ] || limit=$left
  if [ "$limit" -lt 3 ]; then
    skip "$name" "$kind" "out of time: the run's ${budget} s budget is spent"
    return 1
  fi
  echo "[$(elapsed)s] == $name (limit $limit s)"
  local start rc status note=""
  start=$(now_ms)
  timeout -s INT -k 15 "$limit" "$@" >"$out/logs/$name.log" 2>&1
  rc=$?
  case $rc in
    0) status=ok ;;
    124|137) status=timeout; note="stopped after $limit s" ;;
    *) status=failed
       note="exit $rc: $(grep -E '^(error|thread .* panicked)' "$out/logs/$name.log" | tail -1)" ;;
  esac
  record "$name" "$kind" "$status" "$(secs $(($(now_ms) - start)))" "$limit" "$output" "$note"
  [ $rc = 0 ]
}
have_bin() { [ -x "$bin" ]; }

echo "gigawalk GPU run ($([ $quick = 1 ] && echo quick || echo full)) into $out, budget $budget s"

# 1. Build (release; offline first: the GPU machine has no network).
if [ -n "${GIGAWALK_BIN:-}" ]; then
  skip build build "GIGAWALK_BIN given"
elif ! command -v cargo >/dev/null; then
  skip build build "no cargo on PATH"
else
  run_step build build 270 "" bash -c \
    'cargo build --release --locked -p gigawalk --offline || cargo build --release --locked -p gigawalk'
fi
version=$(have_bin && "$bin" --version 2>/dev/null || echo none)

# 2. Scenes: generate + preprocess once per (size, poses, gigawalk version).
prepare() { # name triangles poses -> sets $scene (path without extension)
  local name=$1 tri=$2 n=$3
  scene="$cache/plant-$tri-seed1-${n}poses"
  if ! have_bin; then skip "$name" prepare "no gigawalk binary"; return 1; fi
  if [ -f "$scene.gwk" ] && [ -f "$scene.path" ] && [ "$(cat "$scene.done" 2>/dev/null)" = "$version" ]; then
    record "$name" prepare ok 0 0 "" "cached in $scene.gwk"
    return 0
  fi
  rm -f "$scene.done"
  run_step "$name" prepare "$4" "" bash -c \
    '"$1" generate plant --triangles "$2" --seed 1 --poses "$3" -o "$4.glb" --path "$4.path" &&
     "$1" preprocess "$4.glb" -o "$4.gwk" && rm -f "$4.glb" && printf %s "$5" >"$4.done"' \
    _ "$bin" "$tri" "$n" "$scene" "$version"
}

# 3. Replays: the four modes, accuracy every K-th frame.
replay() { # name scene WxH frames limit [extra replay args]
  local name=$1 s=$2 res=$3 frames=$4 limit=$5
  shift 5
  if ! have_bin; then skip "$name" replay "no gigawalk binary"; return; fi
  run_step "$name" replay "$limit" "$name" "$bin" replay "$s.gwk" --path "$s.path" \
    --out "$out/$name" --width "${res%x*}" --height "${res#*x}" --frames "$frames" \
    --accuracy-every "$every" "$@"
}

if prepare prepare-demo "$demo_tri" "$poses" 90; then
  demo=$scene
  replay "replay-demo-$hi" "$demo" "$hi" "$poses" 60
  replay "replay-demo-$lo" "$demo" "$lo" "$poses" 40
  # 4. Pipelined vs sequential (och, the demo plant, no read-back): the
  # same comparison as benches/pipeline.rs, with the release binary.
  if have_bin; then
    for sched in sequential 1dev 2dev; do
      case $sched in
        sequential) args=(--sequential) ;;
        1dev) args=(--devices 1) ;;
        2dev) args=(--devices 2) ;;
      esac
      run_step "pipeline-$sched" pipeline 30 "pipeline-$sched" "$bin" replay "$demo.gwk" \
        --path "$demo.path" --out "$out/pipeline-$sched" --modes och --accuracy-every 0 \
        --width "${lo%x*}" --height "${lo#*x}" --frames "$pipe_frames" "${args[@]}"
    done
  fi
else
  for n in "replay-demo-$hi" "replay-demo-$lo"; do skip "$n" replay "no demo scene"; done
  for n in sequential 1dev 2dev; do skip "pipeline-$n" pipeline "no demo scene"; done
  demo=""
fi

if prepare prepare-big "$big_tri" "$big_poses" 180; then
  replay "replay-big-$hi" "$scene" "$hi" "$big_poses" 90
  replay "replay-big-$lo" "$scene" "$lo" "$big_poses" 60
  # Out of core: the same walk with the geometry streamed under a budget.
  replay "replay-big-stream-$lo" "$scene" "$lo" "$big_poses" 60 \
    --modes occ,och --memory-budget "$stream_budget"
else
  for n in "replay-big-$hi" "replay-big-$lo" "replay-big-stream-$lo"; do
    skip "$n" replay "no big scene"
  done
fi

# 5. A viewer screenshot: on the display there is, or on Xvfb, or none.
screenshot() {
  local args=(view "$demo.gwk" --path "$demo.path" --frames "$shot_frames"
    --screenshot "$out/viewer.png" --width "${hi%x*}" --height "${hi#*x}")
  if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
    run_step viewer screenshot 40 viewer.png "$bin" "${args[@]}"
  elif command -v Xvfb >/dev/null; then
    local fd="$out/logs/xvfb.display" n="" i
    Xvfb -displayfd 9 -screen 0 "${hi}x24" -nolisten tcp -noreset 9>"$fd" 2>"$out/logs/xvfb.log" &
    local xvfb=$!
    for i in $(seq 50); do n=$(cat "$fd" 2>/dev/null); [ -n "$n" ] && break; sleep 0.2; done
    if [ -n "$n" ]; then
      DISPLAY=":$n" WAYLAND_DISPLAY="" run_step viewer screenshot 60 viewer.png \
        env -u WAYLAND_DISPLAY "$bin" "${args[@]}"
    else
      skip viewer screenshot "Xvfb did not start (logs/xvfb.log)"
    fi
    kill "$xvfb" 2>/dev/null; wait "$xvfb" 2>/dev/null
  else
    skip viewer screenshot "no display: DISPLAY and WAYLAND_DISPLAY unset, no Xvfb"
  fi
}
if [ -n "$demo" ] && have_bin; then screenshot; else skip viewer screenshot "no demo scene"; fi

# 6. benches/pipeline.rs itself (interleaved rounds on the 1M plant), when
# cargo is there and at least 90 s are left: it builds the bench first.
left=$(((deadline - $(now_ms)) / 1000))
if [ $quick = 1 ] || [ -n "${GIGAWALK_BIN:-}" ]; then
  skip bench-pipeline bench "quick run or GIGAWALK_BIN given: no cargo build"
elif ! command -v cargo >/dev/null; then
  skip bench-pipeline bench "no cargo on PATH"
elif [ "$left" -lt 90 ]; then
  skip bench-pipeline bench "only $left s left"
else
  run_step bench-pipeline bench "$left" bench-pipeline.txt bash -c \
    'cargo bench --locked --offline -p gigawalk-suite --bench pipeline >"$1" ||
     cargo bench --locked -p gigawalk-suite --bench pipeline >"$1"' _ "$out/bench-pipeline.txt"
fi

# 7. results.json and summary.md.
total=$(elapsed)
{
  printf 'mode\t%s\n' "$([ $quick = 1 ] && echo quick || echo full)"
  printf 'started_utc\t%s\n' "$(date -u -d "@$((t0 / 1000))" +%FT%TZ 2>/dev/null || date -u +%FT%TZ)"
  printf 'commit\t%s\n' "$(git -C "$repo" rev-parse --short HEAD 2>/dev/null || echo unknown)"
  printf 'gigawalk\t%s\n' "$version"
  printf 'cpus\t%s\n' "$(nproc 2>/dev/null || echo unknown)"
  printf 'os\t%s\n' "$(uname -srm)"
  printf 'budget_s\t%s\n' "$budget"
  printf 'total_s\t%s\n' "$total"
  printf 'scenes\tdemo %s triangles %s poses, big %s triangles %s poses\n' \
    "$demo_tri" "$poses" "$big_tri" "$big_poses"
  printf 'viewports\t%s, %s\n' "$hi" "$lo"
} >>"$out/run.tsv"
echo "[$total s] done; writing results"
if have_bin && "$bin" gpu-run-results "$out"; then
  exit 0
fi
# No binary (the build failed): results.json with the steps alone, so the
# run still says what happened.
esc() { local s=${1//\\/\\\\}; printf '%s' "${s//\"/\\\"}"; }
{
  printf '{\n  "format": "gigawalk-gpu-run 1",\n  "run": {"mode": "%s", "total_s": "%s"},\n' \
    "$([ $quick = 1 ] && echo quick || echo full)" "$total"
  printf '  "adapters": [],\n  "figures": [],\n  "steps": ['
  sep=""
  while IFS=$'\t' read -r n k st s l o note; do
    printf '%s\n    {"name": "%s", "kind": "%s", "status": "%s", "seconds": %s, "timeout_seconds": %s, "output": "%s", "note": "%s"}' \
      "$sep" "$(esc "$n")" "$k" "$st" "$s" "$l" "$(esc "$o")" "$(esc "$note")"
    sep=","
  done <"$out/steps.tsv"
  printf '\n  ]\n}\n'
} >"$out/results.json"
printf '# gigawalk GPU run: no gigawalk binary\n\nSee steps in results.json and logs/.\n' >"$out/summary.md"
exit 1
