#!/usr/bin/env bash
# The browser page against native, on one scene and path at 640x360: the
# page (headless Chromium, WebGPU on SwiftShader, served by `gigawalk
# serve`) at a set of poses in vfc, hlod, occ and och, its first frame after load
# and what it had fetched by then; native replay on lavapipe in vfc,
# hlod, occ and och over the same poses; the speed-ups over vfc side by
# side; the CPU's cost per drawn node (the page's thread against native
# replay on the null adapter, where every GPU operation is free) and the
# page's cost per fetched byte; the bundle's sizes.
#
#   benches/web-page.sh SCENE PATH [POSES]     (POSES: e.g. 0,40,80,120,160)
#
# Needs the bundle (crates/web/build.sh), tests/web-page's packages (npm
# ci there), Chromium, Mesa's lavapipe, and target/release/gigawalk.
set -euo pipefail
[ $# -ge 2 ] || { sed -n 2,12p "$0"; exit 2; }
scene=$1 path=$2 poses=${3:-0,40,80,120,160}
root=$(cd "$(dirname "$0")/.." && pwd)
bin=${GIGAWALK:-$root/target/release/gigawalk}
bundle=${GIGAWALK_WEB_BUNDLE:-$root/target/web/bundle}
# Native replays walk the path up to the last pose asked for.
frames=$(( $(tr ',' '\n' <<< "$poses" | sort -n | tail -1) + 1 ))
out=$(mktemp -d)
trap 'kill $server 2>/dev/null || true; rm -rf "$out"' EXIT
"$bin" serve "$scene" --port 0 --bundle "$bundle" > "$out/url" 2> "$out/serve.log" &
server=$!
for _ in $(seq 50); do [ -s "$out/url" ] && break; sleep 0.1; done
url=$(head -1 "$out/url")
node "$root/tests/web-page/run.mjs" --url "$url" --path "$path" --poses "$poses" \
  --modes vfc,hlod,occ,och --settle 120 --timeout 600 > "$out/page.json"
"$bin" replay "$scene" --path "$path" --frames "$frames" --modes vfc,hlod,occ,och --width 640 \
  --height 360 --accuracy-every 0 --out "$out/native" > "$out/native.log" 2>&1
"$bin" replay "$scene" --path "$path" --frames "$frames" --modes vfc,hlod,occ,och --width 640 \
  --height 360 --accuracy-every 0 --adapter null --out "$out/null" > "$out/null.log" 2>&1
python3 - "$out/page.json" "$out/native/frames.csv" "$poses" "$bundle" "$out/null/frames.csv" <<'PY'
import csv, gzip, json, os, statistics, sys
page = json.load(open(sys.argv[1]))
poses = [int(p) for p in sys.argv[3].split(',')]
first = page['first']
print(f"page: {first['backend']}, first frame {first['first_frame_ms']:.0f} ms after start "
      f"({first['wall_ms']} ms after navigation), fetched {first['first_frame_fetched'] / 1e6:.2f} of "
      f"{first['file_bytes'] / 1e6:.2f} MB by then ({100 * first['first_frame_fetched'] / first['file_bytes']:.1f}%)")
rows = list(csv.DictReader(open(sys.argv[2])))
native = {}
for m in ['vfc', 'hlod', 'occ', 'och']:
    fps = [float(r['fps']) for r in rows if r['mode'] == m and int(r['frame']) in poses and r['fps']]
    tris = [int(r['drawn_triangles']) for r in rows if r['mode'] == m and int(r['frame']) in poses]
    native[m] = (statistics.median(fps) if fps else float('nan'), statistics.median(tris) if tris else 0)
browser = {}
for m in ['vfc', 'hlod', 'occ', 'och']:
    ps = [p for p in page['poses'] if p['mode'] == m]
    if not ps:
        continue
    browser[m] = (statistics.median(p['fps'] for p in ps), statistics.median(p['triangles'] for p in ps),
                  all(p['settled'] for p in ps))
    print(f"page {m}: the page's thread {statistics.median(p['cpu_ms'] for p in ps):.1f} ms a frame, "
          f"traversal {statistics.median(p['traversal_ms'] for p in ps):.1f} ms, "
          f"{statistics.median(p['draws'] for p in ps):.0f} draws, "
          f"{statistics.median(p['waits_per_frame'] for p in ps):.2f} animation frames waiting for OR per frame drawn, "
          f"camera to frame drawn "
          f"{statistics.median(p['hzb_latency_ms'] for p in ps):.0f} ms; settled after "
          f"{', '.join(str(p['settle_ms']) for p in ps)} ms")
print("| mode | browser fps | browser triangles | native lavapipe fps | native triangles | browser / vfc | native / vfc |")
print("|---|---:|---:|---:|---:|---:|---:|")
for m in ['vfc', 'hlod', 'occ', 'och']:
    b = browser.get(m)
    n = native[m]
    bs = f"{b[0] / browser['vfc'][0]:.2f}x" if b else "not in the page"
    print(f"| {m} | {f'{b[0]:.2f}' if b else '-'} | {f'{b[1]:,.0f}' if b else '-'} | {n[0]:.2f} | {n[1]:,.0f} | {bs} | {n[0] / native['vfc'][0]:.2f}x |")
# The CPU per drawn node: the page's thread (all of an animation
# frame's work) against native's stages on the null adapter (OR, HZB,
# STC and RVG: the whole frame there), microseconds, medians over poses.
null = list(csv.DictReader(open(sys.argv[5])))
for m in ['vfc', 'hlod', 'occ', 'och']:
    ps = [p for p in page['poses'] if p['mode'] == m and p['draws']]
    nat = [sum(float(r[k]) for k in ['or_ms', 'hzb_ms', 'stc_ms', 'rvg_ms']) * 1e3 / int(r['drawn_nodes'])
           for r in null if r['mode'] == m and int(r['frame']) in poses and int(r['drawn_nodes'])]
    if ps and nat:
        print(f"{m}: CPU per drawn node: page {statistics.median(p['cpu_ms'] * 1e3 / p['draws'] for p in ps):.2f} us, "
              f"native null adapter {statistics.median(nat):.2f} us")
last = page['last']
if last.get('loaded_bytes'):
    print(f"page: taking in fetched LODs (sparse view, device layout, upload): {last['load_ms']:.0f} ms for "
          f"{last['loaded_bytes'] / 1e6:.2f} MB, {last['load_ms'] / (last['loaded_bytes'] / 1e6):.2f} ms per MB")
print(f"page: LOD blobs asked for in range requests {last['asked_bytes'] / 1e6:.2f} MB, taken in "
      f"{last['loaded_bytes'] / 1e6:.2f} MB; fetched in all (opening, the object table, gaps between "
      f"batched blobs) {last['fetched_bytes'] / 1e6:.2f} MB")
print(f"all poses settled in the page: {all(v[2] for v in browser.values())}; last: fetched "
      f"{page['last']['fetched_bytes'] / 1e6:.2f} MB in {page['last']['requests']} requests")
for f in ['gigawalk_web_bg.wasm', 'gigawalk_web.js', 'main.js', 'index.html']:
    b = open(os.path.join(sys.argv[4], f), 'rb').read()
    print(f"{f}: {len(b):,} bytes, {len(gzip.compress(b, 9)):,} gzipped")
PY
