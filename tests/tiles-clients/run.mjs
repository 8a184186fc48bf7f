// Loads an exported tileset in real clients and writes what they did:
//   node run.mjs --tiles DIR [--validate DIR] --path FILE --pose N --sse S
//                [--chromium /usr/bin/chromium] [--report out.json]
//                [--shots DIR] [--near D]
// 1. the Khronos glTF validator over every content of --validate (and of
//    --tiles): no errors allowed; and the structure checks of
//    structure.mjs on both tilesets as 3d-tiles-tools parses them (errors
//    never increase down the tree, children inside their parents, every
//    content URI resolves): no failure allowed;
// 2. CesiumJS (@cesium/engine) and 3d-tiles-renderer (three.js) in
//    headless Chromium (WebGL2 on SwiftShader), from pose N of a gigawalk
//    camera path at screen-space error S: the tiles and triangles each
//    selected and what each pixel of a 16 x 9 grid picks (feature ID, the
//    object's index and name), the same pixels in both; with --shots, each
//    client's image (cesium.png, threejs.png).
// The tileset is served by a static server this script starts.
import { createServer } from 'node:http';
import { readFileSync, writeFileSync, mkdirSync, existsSync, statSync, mkdtempSync, rmSync } from 'node:fs';
import { join, extname, resolve, dirname } from 'node:path';
import { tmpdir } from 'node:os';
import { fileURLToPath } from 'node:url';
import * as esbuild from 'esbuild';
import puppeteer from 'puppeteer-core';
import { validateAll } from './validate.mjs';
import { checkStructure, summary as structureSummary } from './structure.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
const width = 640, height = 360;

/** Pose N (0-based) of a gigawalk camera path (docs/path-format.md), in the
 *  tileset's frame: scene (y up) to 3D Tiles (z up), x, y, z -> x, -z, y;
 *  the tileset's root transform puts the scene's own coordinates there.
 *  `near`: gigawalk's near plane for the scene (`--near`, model units). */
function pose(pathFile, n, near) {
  const lines = readFileSync(pathFile, 'utf8').split('\n').map((l) => l.replace(/#.*/, '').trim()).filter(Boolean);
  const v = lines[n].split(/\s+/).map(Number);
  const [x, y, z, qx, qy, qz, qw, fovy] = v.slice(1);
  const rotate = ([vx, vy, vz]) => {
    // q * v * q^-1
    const tx = 2 * (qy * vz - qz * vy), ty = 2 * (qz * vx - qx * vz), tz = 2 * (qx * vy - qy * vx);
    return [vx + qw * tx + (qy * tz - qz * ty), vy + qw * ty + (qz * tx - qx * tz), vz + qw * tz + (qx * ty - qy * tx)];
  };
  const zUp = ([a, b, c]) => [a, -c, b];
  return {
    position: zUp([x, y, z]), direction: zUp(rotate([0, 0, -1])), up: zUp(rotate([0, 1, 0])),
    fovy, near, far: 1e5,
  };
}

const types = { '.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json', '.glb': 'model/gltf-binary', '.wasm': 'application/wasm' };

function serve(routes) {
  const server = createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    for (const [prefix, dir] of routes) {
      if (!url.startsWith(prefix)) continue;
      const file = resolve(dir, '.' + url.slice(prefix.length - 1));
      if (!file.startsWith(resolve(dir)) || !existsSync(file) || statSync(file).isDirectory()) break;
      res.writeHead(200, { 'content-type': types[extname(file)] ?? 'application/octet-stream' });
      res.end(readFileSync(file));
      return;
    }
    res.writeHead(404);
    res.end();
  });
  return new Promise((r) => server.listen(0, '127.0.0.1', () => r(server)));
}

async function client(browser, base, name, params, shot) {
  const page = await browser.newPage();
  const log = [];
  page.on('console', (m) => log.push(`${m.type()}: ${m.text()}`));
  page.on('pageerror', (e) => log.push(`pageerror: ${e.message}`));
  await page.setViewport({ width, height });
  await page.goto(`${base}/app/${name}.html#${encodeURIComponent(JSON.stringify(params))}`);
  await page.waitForFunction('window.__result !== undefined', { timeout: 240000, polling: 200 });
  const r = await page.evaluate('window.__result');
  if (shot) await page.screenshot({ path: shot });
  await page.close();
  if (r.error) throw new Error(`${name}: ${r.error}\n${log.join('\n')}`);
  return r;
}

async function main() {
  const result = {};
  const tiles = resolve(args.tiles);
  const v = [];
  for (const d of [args.validate, tiles].filter(Boolean)) v.push(await validateAll(resolve(d)));
  result.validator = {
    contents: v.reduce((a, r) => a + r.files, 0),
    errors: v.reduce((a, r) => a + r.errors, 0),
    warnings: v.reduce((a, r) => a + r.warnings, 0),
    messages: v.flatMap((r) => r.messages),
  };
  console.log(`validator: ${result.validator.contents} contents, ${result.validator.errors} errors, ${result.validator.warnings} warnings`);
  for (const m of result.validator.messages) console.log(`  ${m}`);
  result.structure = [];
  for (const d of [args.validate, tiles].filter(Boolean)) {
    const r = await checkStructure(resolve(d));
    result.structure.push(r);
    console.log(structureSummary(r));
    for (const f of r.failures) console.log(`  ${JSON.stringify(f)}`);
  }

  // The pages, bundled.
  const app = join(here, 'out', 'app');
  mkdirSync(app, { recursive: true });
  for (const name of ['cesium', 'threejs']) {
    writeFileSync(join(app, `${name}.html`), `<!doctype html><html><head><meta charset="utf-8">
<style>html,body,#view{margin:0;width:${width}px;height:${height}px;overflow:hidden}
#view canvas{display:block;width:${width}px;height:${height}px}
.cesium-widget-credits{display:none}</style>
<script>window.CESIUM_BASE_URL = '/cesium/';</script></head>
<body><div id="view"></div><script src="/app/${name}.js"></script></body></html>`);
  }
  await esbuild.build({
    entryPoints: ['cesium', 'threejs'].map((n) => join(here, 'pages', `${n}.js`)),
    bundle: true, format: 'iife', outdir: app, logLevel: 'warning',
    define: { 'process.env.NODE_ENV': '"production"' },
  });
  const engine = join(here, 'node_modules', '@cesium', 'engine');
  const server = await serve([
    ['/tiles/', tiles], ['/app/', app],
    ['/cesium/Workers/', join(engine, 'Build', 'Workers')],
    ['/cesium/ThirdParty/', join(engine, 'Build', 'ThirdParty')],
    ['/cesium/Assets/', join(engine, 'Source', 'Assets')],
  ]);
  const base = `http://127.0.0.1:${server.address().port}`;
  const profile = mkdtempSync(join(tmpdir(), 'gigawalk-chromium-'));
  const browser = await puppeteer.launch({
    executablePath: args.chromium ?? '/usr/bin/chromium',
    headless: true,
    args: [
      '--headless=new', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--no-first-run', `--user-data-dir=${profile}`,
      '--enable-unsafe-swiftshader', '--use-angle=swiftshader',
    ],
  });
  try {
    // Pixel centres of a 16 x 9 grid, (x, y) from the top-left pixel.
    const grid = [];
    for (let j = 0; j < 9; j++) for (let i = 0; i < 16; i++) grid.push([Math.floor((i + 0.5) * width / 16), Math.floor((j + 0.5) * height / 9)]);
    const params = { pose: pose(args.path, Number(args.pose ?? 0), Number(args.near ?? 0.05)), sse: Number(args.sse ?? 16), width, height, grid };
    const summary = (r) => ({ tiles: r.tiles, triangles: r.triangles, webgl2: r.webgl2,
      picked: r.picks.filter(Boolean).length, pick: r.picks.find(Boolean) ?? null });
    result.pose = params.pose;
    result.sse = params.sse;
    result.width = width;
    result.height = height;
    result.grid = grid;
    if (args.shots) mkdirSync(args.shots, { recursive: true });
    for (const name of ['cesium', 'threejs']) {
      const r = await client(browser, base, name, params, args.shots && join(args.shots, `${name}.png`));
      result[name] = { ...summary(r), selected: r.selected, picks: r.picks };
      console.log(`${name}: ${JSON.stringify(summary(r))}`);
    }
  } finally {
    await browser.close();
    server.close();
    rmSync(profile, { recursive: true, force: true });
  }
  if (args.report) writeFileSync(args.report, JSON.stringify(result, null, 1));
  const ok = result.validator.errors === 0 && result.structure.every((r) => r.ok) && result.cesium.pick && result.threejs.pick;
  process.exit(ok ? 0 : 1);
}
main().catch((e) => { console.error(e); process.exit(2); });
