// What a client costs to open an exported tileset: CesiumJS and
// 3d-tiles-renderer in headless Chromium (WebGL2 on SwiftShader), from a
// loopback server, each at a few poses of a gigawalk camera path, each in
// a fresh page without a cache. For each: the requests and bytes of the
// tileset served until the view settles (no tile pending), the time to
// settle from the first request, the tiles and triangles drawn.
//   node bench.mjs --tiles DIR[,DIR...] --path FILE [--poses 0.1,0.5,0.9]
//                  [--sse 16] [--near D] [--chromium PATH] [--report out.json]
// --poses: fractions of the path (0.5: the middle pose) or, with no dot,
// pose indices. --near: gigawalk's near plane (default: its rule, 1e-5 of
// the scene's diagonal, taken from the first tileset's root box).
// Prints a Markdown table; --report writes every figure.
import { readFileSync, writeFileSync } from 'node:fs';
import { resolve, basename, join } from 'node:path';
import { pose, poseLines, serve, pages, chromium, client } from './harness.mjs';

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
if (!args.tiles || !args.path) {
  console.error('usage: node bench.mjs --tiles DIR[,DIR...] --path FILE [--poses 0.1,0.5,0.9] [--sse 16] [--near D] [--report out.json]');
  process.exit(2);
}

async function main() {
  const count = poseLines(args.path).length;
  const poses = (args.poses ?? '0.1,0.5,0.9').split(',').map((p) => (p.includes('.')
    ? Math.min(count - 1, Math.floor(Number(p) * count)) : Number(p)));
  const sse = Number(args.sse ?? 16);
  const near = args.near !== undefined ? Number(args.near) : (() => {
    const b = JSON.parse(readFileSync(join(args.tiles.split(',')[0], 'tileset.json'), 'utf8')).root.boundingVolume.box;
    const half = [0, 1, 2].map((k) => Math.abs(b[3 + k]) + Math.abs(b[6 + k]) + Math.abs(b[9 + k]));
    return 2 * Math.hypot(...half) * 1e-5;
  })();
  const rows = [];
  // One server for every tileset: /tiles/ points at the one being run.
  let tiles = null;
  let served = { requests: 0, bytes: 0, glb: 0, json: 0 };
  const routes = await pages('.');
  const server = await serve(routes.map(([p, d]) => [p, p === '/tiles/' ? () => tiles : d]), (url, bytes) => {
    if (!url.startsWith('/tiles/')) return;
    served.requests += 1;
    served.bytes += bytes;
    if (url.endsWith('.glb')) served.glb += 1;
    if (url.endsWith('.json')) served.json += 1;
  });
  const base = `http://127.0.0.1:${server.address().port}`;
  const { browser, close } = await chromium(args.chromium);
  try {
    for (const dir of args.tiles.split(',')) {
      tiles = resolve(dir);
      for (const n of poses) {
        const params = { pose: pose(args.path, n, near), sse, width: 640, height: 360, grid: [] };
        for (const name of ['cesium', 'threejs']) {
          served = { requests: 0, bytes: 0, glb: 0, json: 0 };
          const r = await client(browser, base, name, params);
          const row = {
            tileset: basename(tiles), pose: n, client: name, ...served,
            settleMs: Math.round(r.settleMs), tiles: r.tiles, triangles: r.triangles,
          };
          rows.push(row);
          console.log(JSON.stringify(row));
        }
      }
    }
  } finally {
    await close();
    server.close();
  }
  console.log(`\n| tileset | pose | client | requests (glb + json) | MB | settle s | tiles drawn | triangles |`);
  console.log('|---|---:|---|---:|---:|---:|---:|---:|');
  for (const r of rows) {
    console.log(`| ${r.tileset} | ${r.pose} | ${r.client === 'cesium' ? 'CesiumJS' : '3d-tiles-renderer'} | ${r.requests} (${r.glb} + ${r.json}) | ${(r.bytes / 1e6).toFixed(2)} | ${(r.settleMs / 1000).toFixed(1)} | ${r.tiles} | ${r.triangles} |`);
  }
  if (args.report) writeFileSync(args.report, JSON.stringify({ sse, poses, rows }, null, 1));
}
main().catch((e) => { console.error(e); process.exit(2); });
