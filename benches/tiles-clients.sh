#!/usr/bin/env bash
# What CesiumJS and 3d-tiles-renderer pay to open gigawalk's 3D Tiles
# export: requests and bytes until the view settles, time to settle,
# tiles and triangles drawn, at three poses of the scene's camera path
# (10%, 50% and 90% along it), in headless Chromium from a loopback
# server (tests/tiles-clients/bench.mjs; docs/tiles.md has the figures).
#
#   benches/tiles-clients.sh PATH TILES_DIR [TILES_DIR...]
#
# PATH is the .path `gigawalk generate ... --path` wrote; each TILES_DIR
# an export (`gigawalk export-tiles scene.gwk -o DIR`). SSE (default 16,
# CesiumJS's default) sets the screen-space error, POSES the poses
# (fractions of the path, or indices), REPORT a JSON file for every
# figure. Needs node and chromium (`npm ci --prefix tests/tiles-clients`).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 2 ]; then
  sed -n '2,15p' "$0"
  exit 2
fi
path=$(realpath "$1")
shift
dirs=()
for d in "$@"; do
  [ -f "$d/tileset.json" ] || { echo "$d: no tileset.json" >&2; exit 2; }
  dirs+=("$(realpath "$d")")
done
list=$(IFS=,; echo "${dirs[*]}")
report=${REPORT:+$(realpath -m "$REPORT")}
[ -d tests/tiles-clients/node_modules ] || npm ci --prefix tests/tiles-clients
cd tests/tiles-clients
node bench.mjs --tiles "$list" --path "$path" --poses "${POSES:-0.1,0.5,0.9}" \
  --sse "${SSE:-16}" ${CHROMIUM:+--chromium "$CHROMIUM"} ${report:+--report "$report"}
