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
import { writeFileSync, mkdirSync } from 'node:fs';
import { join, resolve } from 'node:path';
import { validateAll } from './validate.mjs';
import { checkStructure, summary as structureSummary } from './structure.mjs';
import { pose, serve, pages, chromium, client, width, height } from './harness.mjs';

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];

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

  const server = await serve(await pages(tiles));
  const base = `http://127.0.0.1:${server.address().port}`;
  const { browser, close } = await chromium(args.chromium);
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
    await close();
    server.close();
  }
  if (args.report) writeFileSync(args.report, JSON.stringify(result, null, 1));
  const ok = result.validator.errors === 0 && result.structure.every((r) => r.ok) && result.cesium.pick && result.threejs.pick;
  process.exit(ok ? 0 : 1);
}
main().catch((e) => { console.error(e); process.exit(2); });
