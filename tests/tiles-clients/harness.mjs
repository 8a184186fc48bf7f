// What run.mjs and bench.mjs share: a pose of a gigawalk camera path in
// the tileset's frame, a loopback static server, the client pages bundled,
// and headless Chromium.
import { createServer } from 'node:http';
import { readFileSync, writeFileSync, mkdirSync, existsSync, statSync, mkdtempSync, rmSync } from 'node:fs';
import { join, extname, resolve, dirname } from 'node:path';
import { tmpdir } from 'node:os';
import { fileURLToPath } from 'node:url';
import * as esbuild from 'esbuild';
import puppeteer from 'puppeteer-core';

const here = dirname(fileURLToPath(import.meta.url));
export const width = 640, height = 360;

/** Pose N (0-based) of a gigawalk camera path (docs/path-format.md), in the
 *  tileset's frame: scene (y up) to 3D Tiles (z up), x, y, z -> x, -z, y;
 *  the tileset's root transform puts the scene's own coordinates there.
 *  `near`: gigawalk's near plane for the scene (`--near`, model units). */
export function pose(pathFile, n, near) {
  const lines = poseLines(pathFile);
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

/** The pose lines of a camera path (comments and blank lines left out). */
export function poseLines(pathFile) {
  return readFileSync(pathFile, 'utf8').split('\n').map((l) => l.replace(/#.*/, '').trim()).filter(Boolean);
}

const types = { '.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json', '.glb': 'model/gltf-binary', '.wasm': 'application/wasm' };

/** A static server on 127.0.0.1 (an ephemeral port) of `routes`, [URL
 *  prefix, directory] pairs (a directory may be a function giving it at
 *  each request). `onServe(url, bytes)` hears every file sent. */
export function serve(routes, onServe = () => {}) {
  const server = createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    for (const [prefix, route] of routes) {
      if (!url.startsWith(prefix)) continue;
      const dir = typeof route === 'function' ? route() : route;
      const file = resolve(dir, '.' + url.slice(prefix.length - 1));
      if (!file.startsWith(resolve(dir)) || !existsSync(file) || statSync(file).isDirectory()) break;
      const body = readFileSync(file);
      onServe(url, body.length);
      res.writeHead(200, { 'content-type': types[extname(file)] ?? 'application/octet-stream' });
      res.end(body);
      return;
    }
    res.writeHead(404);
    res.end();
  });
  return new Promise((r) => server.listen(0, '127.0.0.1', () => r(server)));
}

/** The client pages (cesium, threejs), bundled into out/app; the server's
 *  routes for them and CesiumJS's assets, and `tiles` under /tiles/. */
export async function pages(tiles) {
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
  return [
    ['/tiles/', tiles], ['/app/', app],
    ['/cesium/Workers/', join(engine, 'Build', 'Workers')],
    ['/cesium/ThirdParty/', join(engine, 'Build', 'ThirdParty')],
    ['/cesium/Assets/', join(engine, 'Source', 'Assets')],
  ];
}

/** Headless Chromium, WebGL2 on SwiftShader; `close()` also removes its
 *  profile. */
export async function chromium(executablePath) {
  const profile = mkdtempSync(join(tmpdir(), 'gigawalk-chromium-'));
  const browser = await puppeteer.launch({
    executablePath: executablePath ?? '/usr/bin/chromium',
    headless: true,
    args: [
      '--headless=new', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--no-first-run', `--user-data-dir=${profile}`,
      '--enable-unsafe-swiftshader', '--use-angle=swiftshader',
    ],
  });
  return { browser, close: async () => { await browser.close(); rmSync(profile, { recursive: true, force: true }); } };
}

/** Opens client page `name` with `params` (its hash) in a new page without
 *  a cache, waits for its report and returns it (and, with `shot`, writes
 *  the page's image there). */
export async function client(browser, base, name, params, shot) {
  const page = await browser.newPage();
  await page.setCacheEnabled(false);
  const log = [];
  page.on('console', (m) => log.push(`${m.type()}: ${m.text()}`));
  page.on('pageerror', (e) => log.push(`pageerror: ${e.message}`));
  await page.setViewport({ width, height });
  await page.goto(`${base}/app/${name}.html#${encodeURIComponent(JSON.stringify(params))}`);
  await page.waitForFunction('window.__result !== undefined', { timeout: 290000, polling: 200 });
  const r = await page.evaluate('window.__result');
  if (shot) await page.screenshot({ path: shot });
  await page.close();
  if (r.error) throw new Error(`${name}: ${r.error}\n${log.join('\n')}`);
  return r;
}
