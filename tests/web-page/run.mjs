// Drives gigawalk's browser page (crates/web) in headless Chromium with
// WebGPU on SwiftShader, and prints a JSON report: what the page said
// (its stats, or its error), and with --path, each pose's triangles,
// frame rate and how much of the image the scene covers, per mode.
//
//   node run.mjs --url URL [--query Q] [--fragment F] [--path FILE --poses 0,10,20]
//                [--modes vfc,hlod] [--shots DIR] [--timeout S]
//                [--settle S] [--linger S] [--no-hud] [--compare M:REF,...]
//                [--serve DIR [--no-range]] [--no-webgpu [--no-webgl]]
//                [--review POSE --pick X,Y [--measure X,Y] [--downloads DIR]]
//                [--look-walk POSE [--cap X,Y]] [--look auto|plain] [--frames DIR]
//
// --serve DIR serves DIR itself (ranges answered, or with --no-range
// every request answered whole, as a server without range support
// does) and opens it instead of --url. --settle bounds the wait for a
// pose to draw all it wants (a budget too small never lets it);
// --linger waits before the last stats. --no-webgpu starts Chromium
// without WebGPU (the page falls back to WebGL2), --no-webgl without
// WebGL too. --no-hud hides the HUD; --compare occ:vfc,och:hlod
// compares mode M's image at each pose with mode REF's (run before it),
// pixel by pixel ("diff": pixels that differ, and the largest difference
// of a channel). --fragment F opens the page at URL#F (a view link).
// --frames DIR writes each pose's frame as RVG drew it
// (window.gigawalk.readFrame): MODE-POSE.rgba (8-bit RGBA rows) and
// MODE-POSE.depth (f32, little endian), its size in the report's rows.
// --review POSE walks the review tools at that pose of --path (after
// the modes), as a user does, in occ with the HUD off: pick at pixel
// X,Y; click it (select); X with the pointer there (a section plane);
// H (hide it); occ against vfc with both; E (edges: the image shown
// changes, the frame read back does not) and F4 (x-ray: the hidden object
// as a ghost); the view's link opened in a second tab; U and Delete (show all, no section);
// with --measure, M and clicks at X,Y of --pick and of --measure (the
// distance in the stats), then Esc; with --downloads, P (a screenshot)
// and R, a second of W, R (a recorded path), both downloaded into DIR;
// a finger dragged across the canvas (touch). Each step's stats, picks
// and image comparisons are in the report's "review". --look-walk POSE
// shows that pose with the HUD off and turns each look pass on alone (E
// edges, F2 AO, F3 FXAA): the report's "look" has, per pass, the pixels
// it changed among those the frame read back shows geometry at (its
// depth), by region of the canvas (its left and right halves), and
// whether the frame read back stayed the same ("readback_sum" is the
// starting frame's checksum). --look sets the page's
// look (?look=, plain unless given). With --cap X,Y it then cuts at that
// pixel (X, and ] four times) and reports the frame's row there before
// and after ("cap_before", "cap"). Exit status 0 whenever a
// report was written (tests judge it); 2 when Chromium or the page could
// not be driven at all.
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import { execFileSync } from 'node:child_process';
import puppeteer from 'puppeteer-core';

const args = process.argv.slice(2);
const opt = (name, dflt) => {
  const i = args.indexOf(`--${name}`);
  return i >= 0 && i + 1 < args.length ? args[i + 1] : dflt;
};
const flag = (name) => args.includes(`--${name}`);
const timeoutMs = Number(opt('timeout', '180')) * 1000;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/// Chromium's own SwiftShader Vulkan driver: WebGPU needs a Vulkan ICD.
function swiftshaderIcd() {
  if (process.env.VK_ICD_FILENAMES) return process.env.VK_ICD_FILENAMES;
  for (const p of ['/usr/lib/chromium/vk_swiftshader_icd.json']) if (fs.existsSync(p)) return p;
  try {
    const listed = execFileSync('dpkg', ['-L', 'chromium-common'], { encoding: 'utf8' });
    return listed.split('\n').find((l) => l.endsWith('vk_swiftshader_icd.json'));
  } catch (e) { return undefined; }
}

function serve(dir, ranges) {
  const types = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm', '.json': 'application/json' };
  const server = http.createServer((req, res) => {
    const name = path.basename(decodeURIComponent(new URL(req.url, 'http://x').pathname)) || 'index.html';
    const file = path.join(dir, name);
    if (!fs.existsSync(file)) { res.writeHead(404); res.end(); return; }
    const len = fs.statSync(file).size;
    const head = { 'Content-Type': types[path.extname(file)] || 'application/octet-stream' };
    const m = /^bytes=(\d+)-(\d*)$/.exec(req.headers.range || '');
    if (ranges && m && Number(m[1]) < len) {
      const s = Number(m[1]);
      const e = m[2] ? Math.min(Number(m[2]), len - 1) : len - 1;
      res.writeHead(206, { ...head, 'Accept-Ranges': 'bytes', 'Content-Range': `bytes ${s}-${e}/${len}`, 'Content-Length': e - s + 1 });
      fs.createReadStream(file, { start: s, end: e }).pipe(res);
    } else {
      res.writeHead(200, { ...head, 'Content-Length': len });
      fs.createReadStream(file).pipe(res);
    }
  });
  return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}

const report = { pages: [] };
let server;
let browser;
try {
  let url = opt('url');
  if (opt('serve')) {
    server = await serve(opt('serve'), !flag('no-range'));
    url = `http://127.0.0.1:${server.address().port}/`;
  }
  if (!url) throw new Error('--url or --serve is needed');
  const webgpu = flag('no-webgpu')
    ? ['--disable-webgpu', ...(flag('no-webgl') ? ['--disable-3d-apis', '--disable-webgl'] : [])]
    : ['--enable-unsafe-webgpu', '--enable-features=Vulkan', '--use-vulkan=swiftshader', '--use-angle=vulkan'];
  browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: 'new',
    env: { ...process.env, VK_ICD_FILENAMES: swiftshaderIcd() || '' },
    args: ['--no-sandbox', '--disable-background-networking', '--disable-component-update',
      '--no-first-run', '--disable-sync', '--disable-quic', ...webgpu],
  });
  const page = await browser.newPage();
  const consoleLines = [];
  page.on('console', (m) => consoleLines.push(`${m.type()}: ${m.text()}`.slice(0, 500)));
  page.on('pageerror', (e) => consoleLines.push(`pageerror: ${e.message}`.slice(0, 500)));
  await page.setViewport({ width: 640, height: 360 });
  const query = ['size=640x360', `look=${opt('look', 'plain')}`, opt('query')].filter(Boolean).join('&');
  const started = Date.now();
  await page.goto(`${url}?${query}${opt('fragment') ? `#${opt('fragment')}` : ''}`);
  const stats = () => page.evaluate(() => (window.gigawalkStats ? window.gigawalkStats() : { state: 'loading' }));
  let s = await stats();
  while (s.state !== 'error' && !(s.state === 'running' && s.frames > 0) && Date.now() - started < timeoutMs) {
    await sleep(100);
    s = await stats();
  }
  report.first = { ...s, wall_ms: Date.now() - started };
  // The page shows an error once start() has rejected, just after the
  // stats say so.
  const shown = () => page.evaluate(() => document.getElementById('status')?.className === 'error');
  for (let i = 0; s.state === 'error' && i < 50 && !(await shown()); i++) await sleep(100);
  report.status_text = await page.evaluate(() => document.getElementById('status')?.textContent || '');
  const shots = opt('shots');
  if (shots) fs.mkdirSync(shots, { recursive: true });

  // A base64 PNG's RGBA pixels and width, decoded in the page.
  await page.evaluate(() => {
    window.gigawalkPngPixels = async (data) => {
      const img = new Image();
      img.src = `data:image/png;base64,${data}`;
      await img.decode();
      const c = document.createElement('canvas');
      c.width = img.width; c.height = img.height;
      const g = c.getContext('2d');
      g.drawImage(img, 0, 0);
      return { d: g.getImageData(0, 0, c.width, c.height).data, width: c.width, height: c.height };
    };
    // Pixels of two RGBA arrays with any colour channel different, and
    // the largest difference of a channel.
    window.gigawalkPixelDiff = (da, db) => {
      if (da.length !== db.length) return { pixels: -1, max: 255 };
      let n = 0; let max = 0;
      for (let i = 0; i < da.length; i += 4) {
        let d = 0;
        for (let k = 0; k < 3; k++) d = Math.max(d, Math.abs(da[i + k] - db[i + k]));
        if (d > 0) n++;
        max = Math.max(max, d);
      }
      return { pixels: n, max };
    };
  });

  /// How two screenshots (base64 PNGs of one size) differ: pixels with
  /// any channel different, and the largest difference of a channel.
  const diff = (a, b) => page.evaluate(async (pa, pb) => window.gigawalkPixelDiff(
    (await window.gigawalkPngPixels(pa)).d, (await window.gigawalkPngPixels(pb)).d), a, b);

  /// The page as a PNG (base64), kept under --shots as NAME.png.
  async function shot(name) {
    const png = await page.screenshot({ encoding: 'base64' });
    if (shots) fs.writeFileSync(path.join(shots, `${name}.png`), Buffer.from(png, 'base64'));
    return png;
  }

  /// The share of the page's pixels that are not the background (the
  /// HUD's rows left out).
  async function coverage(png) {
    return page.evaluate(async (data, hudRows) => {
      const { d, width, height } = await window.gigawalkPngPixels(data);
      const c = { width, height };
      const bg = [d[d.length - 4], d[d.length - 3], d[d.length - 2]];
      let lit = 0;
      // The HUD's panel (top left) is left out.
      for (let y = hudRows; y < c.height; y++) {
        for (let x = 0; x < c.width; x++) {
          const i = 4 * (y * c.width + x);
          if (Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) + Math.abs(d[i + 2] - bg[2]) > 12) lit++;
        }
      }
      return lit / (c.width * (c.height - hudRows));
    }, png, flag('no-hud') ? 0 : 60);
  }

  /// Waits until the page has drawn all it wants, a few frames after
  /// now; its stats then.
  async function settle(p = page) {
    const st = () => p.evaluate(() => window.gigawalkStats());
    const t0 = Date.now();
    const f0 = (await st()).frames;
    let x = await st();
    while (!(x.settled && x.frames >= f0 + 3) && x.state !== 'error' && Date.now() - t0 < timeoutMs / 4) {
      await sleep(100);
      x = await st();
    }
    return x;
  }

  /// Polls until `ok(stats)` holds (or a quarter of the timeout).
  async function until(ok) {
    const t0 = Date.now();
    let x = await stats();
    while (!ok(x) && Date.now() - t0 < timeoutMs / 4) { await sleep(100); x = await stats(); }
    return x;
  }

  /// The review tools at `pose`, pixel (px, py): see the header.
  async function review(p, pose, [px, py]) {
    const r = { pose, pixel: [px, py] };
    await p.evaluate(() => window.gigawalk.setHud(false));
    await p.evaluate(() => window.gigawalk.setMode('occ'));
    await p.evaluate((i) => window.gigawalk.showPose(i), pose);
    r.before = await settle();
    const before = await shot('review-before');
    await until((x) => x.objects !== null);
    r.pick = await p.evaluate((x, y) => window.gigawalk.pick(x, y), px, py);
    // A click with the mouse selects what is there.
    await p.mouse.click(px + 0.5, py + 0.5);
    r.selected = (await until((x) => x.selected !== null)).selected;
    r.selected_stats = await settle();
    // A section plane where the pointer is, facing the eye.
    await p.mouse.move(px + 0.5, py + 0.5);
    await p.keyboard.press('KeyX');
    await until((x) => x.section !== null);
    r.cut = await settle();
    const cut = await shot('review-cut');
    r.pick_cut = await p.evaluate((x, y) => window.gigawalk.pick(x, y), px, py);
    await p.keyboard.press('KeyH');
    await until((x) => x.hidden > 0);
    r.hidden = await settle();
    const hidden = await shot('review-hidden');
    r.hidden_vs_cut = await diff(cut, hidden);
    r.pick_hidden = await p.evaluate((x, y) => window.gigawalk.pick(x, y), px, py);
    r.view = await p.evaluate(() => window.gigawalk.view());
    // With the section and the hidden object, occlusion culling against
    // frustum culling alone.
    await p.evaluate(() => window.gigawalk.setMode('vfc'));
    r.hidden_vfc = await settle();
    r.occ_vs_vfc = await diff(await shot('review-hidden-vfc'), hidden);
    await p.evaluate(() => window.gigawalk.setMode('occ'));
    await settle();
    // Edges (E) change the shown image and not the frame read back for
    // accuracy; x-ray (F4) shows the hidden object as a ghost.
    const frameSum = () => p.evaluate(async () => {
      const f = await window.gigawalk.readFrame();
      let h = 0;
      for (const v of f.colour) h = (Math.imul(h, 31) + v) >>> 0;
      for (const d of f.depth) h = (Math.imul(h, 31) + Math.round(d * 1e7)) >>> 0;
      return h;
    });
    const drawnPlain = await frameSum();
    await p.keyboard.press('KeyE');
    await settle();
    r.edges_vs_hidden = await diff(hidden, await shot('review-edges'));
    r.edges_readback_same = (await frameSum()) === drawnPlain;
    await p.keyboard.press('KeyE');
    await p.keyboard.press('F4');
    r.xray = await settle();
    const xray = await shot('review-xray');
    r.xray_vs_hidden = await diff(hidden, xray);
    // The view's link (x-ray on) in a second tab shows the same image.
    r.link = await p.evaluate(() => window.gigawalk.viewLink());
    const tab = await browser.newPage();
    await tab.setViewport({ width: 640, height: 360 });
    await tab.goto(r.link);
    const tabStats = () => tab.evaluate(() => (window.gigawalkStats ? window.gigawalkStats() : { state: 'loading' }));
    const t0 = Date.now();
    let x = await tabStats();
    while (!(x.state === 'running' && x.objects !== null && x.hidden > 0) && x.state !== 'error' && Date.now() - t0 < timeoutMs / 4) {
      await sleep(100);
      x = await tabStats();
    }
    await tab.evaluate(() => { window.gigawalk.setHud(false); window.gigawalk.setMode('occ'); });
    r.link_stats = await settle(tab);
    const linked = await tab.screenshot({ encoding: 'base64' });
    if (shots) fs.writeFileSync(path.join(shots, 'review-link.png'), Buffer.from(linked, 'base64'));
    r.link_vs_xray = await diff(xray, linked);
    await tab.close();
    // U shows all again; Delete clears the section: the first image.
    await p.bringToFront();
    await p.keyboard.press('F4');
    await p.keyboard.press('KeyU');
    await p.keyboard.press('Delete');
    await until((x) => x.hidden === 0 && x.section === null);
    r.restored = await settle();
    const restored = await shot('review-restored');
    r.restored_vs_before = await diff(before, restored);
    if (opt('measure')) {
      const [mx, my] = opt('measure').split(',').map(Number);
      await p.keyboard.press('KeyM');
      await p.mouse.click(px + 0.5, py + 0.5);
      await until((x) => (x.message || '').includes('second point'));
      await p.mouse.click(mx + 0.5, my + 0.5);
      r.measure = await until((x) => x.measured !== null);
      // The segment and its label are drawn over the frame.
      r.measure_vs_restored = await diff(restored, await shot('review-measure'));
      await p.keyboard.press('Escape');
      r.measure_cleared = await until((x) => x.measured === null);
    }
    if (opt('downloads')) {
      const dir = opt('downloads');
      fs.mkdirSync(dir, { recursive: true });
      const cdp = await p.createCDPSession();
      await cdp.send('Browser.setDownloadBehavior', { behavior: 'allow', downloadPath: dir });
      // The frame as RVG drew it: with the HUD off and a plain look, the
      // canvas shows exactly that (the page's screenshot also has the
      // page's own help line, which is not the canvas).
      const drawn = await p.evaluate(async () => Array.from((await window.gigawalk.readFrame()).colour));
      await p.keyboard.press('KeyP');
      await p.keyboard.press('KeyR');
      await until((x) => x.recording !== null);
      await p.keyboard.down('KeyW');
      await sleep(1000);
      await p.keyboard.up('KeyW');
      await p.keyboard.press('KeyR');
      r.recorded = await until((x) => x.recording === null && x.downloads.length >= 2);
      const done = () => fs.readdirSync(dir).filter((f) => !f.endsWith('.crdownload'));
      const t0 = Date.now();
      while (done().length < 2 && Date.now() - t0 < 20000) await sleep(100);
      r.downloads = done();
      const png = r.downloads.find((f) => f.endsWith('.png'));
      if (png) {
        r.screenshot_vs_drawn = await p.evaluate(async (data, want) => {
          const { d, width, height } = await window.gigawalkPngPixels(data);
          return { ...window.gigawalkPixelDiff(d, want), width, height };
        }, fs.readFileSync(path.join(dir, png)).toString('base64'), drawn);
      }
    }
    // A finger dragged across the canvas looks around, as the mouse does.
    const viewBefore = await p.evaluate(() => window.gigawalk.view());
    await p.touchscreen.touchStart(200, 180);
    await p.touchscreen.touchMove(260, 180);
    await p.touchscreen.touchMove(320, 180);
    await p.touchscreen.touchEnd();
    await sleep(300);
    const viewAfter = await p.evaluate(() => window.gigawalk.view());
    r.touch = { before: viewBefore.orientation, after: viewAfter.orientation };
    return r;
  }

  /// Each look pass alone at `pose`: see the header.
  async function lookWalk(p, pose) {
    await p.evaluate(() => window.gigawalk.setHud(false));
    await p.evaluate((i) => window.gigawalk.showPose(i), pose);
    const out = { before: await settle() };
    const plain = await shot('look-plain');
    const frame = () => p.evaluate(async () => {
      const f = await window.gigawalk.readFrame();
      let h = 0;
      for (const v of f.colour) h = (Math.imul(h, 31) + v) >>> 0;
      return { sum: h, depth: Array.from(f.depth, (d) => (d > 0 ? 1 : 0)), width: f.width };
    });
    const drawn = await frame();
    out.readback_sum = drawn.sum;
    for (const [name, key] of [['edges', 'KeyE'], ['ao', 'F2'], ['fxaa', 'F3']]) {
      await p.keyboard.press(key);
      out[`${name}_stats`] = await settle();
      const png = await shot(`look-${name}`);
      const f = await frame();
      await p.keyboard.press(key);
      await settle();
      // Pixels changed, by half of the canvas; "inside": geometry at the
      // pixel and at every pixel within 3 (no silhouette near).
      out[name] = await p.evaluate(async (a, b, depth, w) => {
        const da = (await window.gigawalkPngPixels(a)).d;
        const db = (await window.gigawalkPngPixels(b)).d;
        const h = depth.length / w;
        const at = (x, y) => x >= 0 && y >= 0 && x < w && y < h && depth[y * w + x] === 1;
        const r = { left: 0, right: 0, left_inside: 0, right_inside: 0, left_inside_pixels: 0, right_inside_pixels: 0, background: 0 };
        for (let y = 0; y < h; y++) {
          for (let x = 0; x < w; x++) {
            const i = 4 * (y * w + x);
            let d = 0;
            for (let k = 0; k < 3; k++) d = Math.max(d, Math.abs(da[i + k] - db[i + k]));
            const side = x < w / 2 ? 'left' : 'right';
            let inside = at(x, y);
            for (let dy = -3; inside && dy <= 3; dy++) for (let dx = -3; inside && dx <= 3; dx++) inside = at(x + dx, y + dy);
            if (inside) r[`${side}_inside_pixels`]++;
            if (d <= 8) continue;
            if (!at(x, y)) r.background++;
            else r[side]++;
            if (inside) r[`${side}_inside`]++;
          }
        }
        return r;
      }, plain, png, drawn.depth, drawn.width);
      out[name].readback_same = f.sum === drawn.sum;
    }
    if (opt('cap')) {
      // A section plane through the surface at X,Y, facing the eye (X),
      // moved four steps deeper (]): along the frame's row there, the
      // luma's low and high and how often it crosses their middle (a
      // hatched cap's stripes cross it again and again).
      const [cx, cy] = opt('cap').split(',').map(Number);
      const row = () => p.evaluate(async (x0, y) => {
        const f = await window.gigawalk.readFrame();
        const l = [];
        for (let x = x0 - 16; x <= x0 + 16; x++) {
          const i = 4 * (y * f.width + x);
          l.push(0.2126 * f.colour[i] + 0.7152 * f.colour[i + 1] + 0.0722 * f.colour[i + 2]);
        }
        const lo = Math.min(...l); const hi = Math.max(...l);
        let crossings = 0;
        for (let k = 1; k < l.length; k++) if ((l[k] > (lo + hi) / 2) !== (l[k - 1] > (lo + hi) / 2)) crossings++;
        return { lo, hi, crossings };
      }, cx, cy);
      out.cap_before = await row();
      await p.mouse.move(cx + 0.5, cy + 0.5);
      await p.keyboard.press('KeyX');
      await until((x) => x.section !== null);
      for (let i = 0; i < 4; i++) await p.keyboard.press('BracketRight');
      out.cap_stats = await settle();
      await shot('look-cap');
      out.cap = await row();
    }
    return out;
  }

  if (opt('look-walk') && opt('path') && s.state === 'running') {
    await page.evaluate((t) => window.gigawalk.loadPath(t), fs.readFileSync(opt('path'), 'utf8'));
    report.look = await lookWalk(page, Number(opt('look-walk')));
  }
  if (opt('path') && s.state === 'running') {
    const poses = (opt('poses') || '0').split(',').map(Number);
    report.path_poses = await page.evaluate((t) => window.gigawalk.loadPath(t), fs.readFileSync(opt('path'), 'utf8'));
    report.poses = [];
    if (flag('no-hud')) await page.evaluate(() => window.gigawalk.setHud(false));
    const references = new Map((opt('compare') || '').split(',').filter(Boolean).map((c) => c.split(':')));
    const images = new Map();
    for (const mode of (opt('modes') || 'vfc,hlod').split(',')) {
      await page.evaluate((m) => window.gigawalk.setMode(m), mode);
      for (const pose of poses) {
        await page.evaluate((i) => window.gigawalk.showPose(i), pose);
        const t0 = Date.now();
        const f0 = (await stats()).frames;
        // Settled: every wanted LOD drawn, nothing in flight, a few
        // frames after the pose was set.
        let p = await stats();
        const settleMs = Number(opt('settle', String(timeoutMs / 4000))) * 1000;
        while (!(p.settled && p.frames >= f0 + 3) && p.state !== 'error' && Date.now() - t0 < settleMs) {
          await sleep(100);
          p = await stats();
        }
        const settle_ms = Date.now() - t0;
        // Frame rate over two seconds at the settled pose.
        const a = await stats();
        const ta = Date.now();
        await sleep(2000);
        const b = await stats();
        const fps = ((b.frames - a.frames) * 1000) / (Date.now() - ta);
        const png = await shot(`${mode}-${pose}`);
        let frame;
        if (opt('frames')) {
          fs.mkdirSync(opt('frames'), { recursive: true });
          const f = await page.evaluate(async () => {
            const r = await window.gigawalk.readFrame();
            const b64 = (u8) => {
              let s = '';
              for (let i = 0; i < u8.length; i += 0x8000) s += String.fromCharCode(...u8.subarray(i, i + 0x8000));
              return btoa(s);
            };
            return { width: r.width, height: r.height, colour: b64(r.colour), depth: b64(new Uint8Array(r.depth.buffer)) };
          });
          fs.writeFileSync(path.join(opt('frames'), `${mode}-${pose}.rgba`), Buffer.from(f.colour, 'base64'));
          fs.writeFileSync(path.join(opt('frames'), `${mode}-${pose}.depth`), Buffer.from(f.depth, 'base64'));
          frame = { width: f.width, height: f.height };
        }
        images.set(`${mode}-${pose}`, png);
        // Animation frames that waited for OR's read-back in those two
        // seconds, per frame drawn.
        const waits = (b.hzb_waits - a.hzb_waits) / Math.max(1, b.frames - a.frames);
        const row = { mode, pose, settle_ms, fps, waits_per_frame: waits, coverage: await coverage(png), frame, ...b };
        const ref = images.get(`${references.get(mode)}-${pose}`);
        if (ref) row.diff = { against: references.get(mode), ...(await diff(ref, png)) };
        report.poses.push(row);
      }
    }
  }
  if (opt('review') && opt('path') && s.state === 'running') {
    report.review = await review(page, Number(opt('review')), opt('pick', '320,180').split(',').map(Number));
  }
  await sleep(Number(opt('linger', '0')) * 1000);
  report.last = await stats();
  report.console = consoleLines.slice(-40);
  console.log(JSON.stringify(report, null, 1));
} catch (e) {
  console.error(`cannot drive the page: ${e && e.stack ? e.stack : e}`);
  process.exitCode = 2;
} finally {
  if (browser) await browser.close();
  if (server) server.close();
}
