// Checks a tileset's structure on what 3d-tiles-tools (CesiumGS's own
// 3D Tiles library) parses, following external tilesets through its
// traversal:
//   node structure.mjs DIR [DIR ...] [--report out.json] [--epsilon E]
// - geometric errors never increase from a tile to its children (an
//   external tileset's root counts as the child of the tile that
//   references it);
// - each child's bounding box lies inside its parent's (the child's eight
//   corners, through the child's own transform if it has one, inside the
//   parent's oriented box, within E of its half axes; 1e-7 by default),
//   and each content's box inside its tile's;
// - every content URI resolves to a file, which is a glb or a tileset;
// - the tileset's own geometric error is at least its root's.
// Prints a line a tileset and exits non-zero when any check fails (or a
// tileset cannot be read); --report writes the reports as JSON.
import {
  BoundingVolumes,
  BoundingVolumesContainment,
  BufferedContentData,
  ContentDataTypeRegistry,
  ContentDataTypes,
  TilesetSourceResourceResolver,
  TilesetSources,
  TilesetTraverser,
} from '3d-tiles-tools';

/** At most this many failures are listed a tileset; all are counted. */
const LISTED = 50;

/** `p` (3 numbers) through a column-major 4x4 `m`. */
function transformPoint(m, [x, y, z]) {
  return [
    m[0] * x + m[4] * y + m[8] * z + m[12],
    m[1] * x + m[5] * y + m[9] * z + m[13],
    m[2] * x + m[6] * y + m[10] * z + m[14],
  ];
}

function isBox(b) {
  return Array.isArray(b) && b.length === 12 && b.every(Number.isFinite);
}

/** Whether the box `inner` (12 numbers, in a frame that `transform`, when
 *  given, takes to `outer`'s) lies inside the box `outer`: a box is
 *  convex, so it does when its eight corners do. */
export function boxInside(inner, transform, outer, epsilon) {
  for (let corner of BoundingVolumes.computeBoundingVolumeBoxCorners(inner)) {
    if (transform) corner = transformPoint(transform, corner);
    if (!BoundingVolumesContainment.boxContains(outer, corner, epsilon)) return false;
  }
  return true;
}

export async function checkStructure(dir, { epsilon = 1e-7 } = {}) {
  const r = {
    tileset: dir,
    // Tiles as the traversal visits them: an external tileset's root is
    // visited beside the tile that references it.
    tiles: 0,
    externalTilesets: 0,
    contents: 0,
    glb: 0,
    maxDepth: 0,
    checked: { errors: 0, boxes: 0, contentBoxes: 0, uris: 0 },
    failed: { errors: 0, boxes: 0, contentBoxes: 0, uris: 0, read: 0 },
    failures: [],
  };
  const fail = (kind, what) => {
    r.failed[kind]++;
    if (r.failures.length < LISTED) r.failures.push({ kind, ...what });
  };

  let source;
  try {
    source = await TilesetSources.createAndOpen(dir);
    const tileset = await TilesetSources.parseSourceValue(source, 'tileset.json');
    const root = tileset?.root;
    if (!root) throw new Error('tileset.json has no root tile');
    r.checked.errors++;
    if (!(tileset.geometricError >= root.geometricError)) {
      fail('errors', { tile: '/root', error: root.geometricError, parentError: tileset.geometricError, why: "the root's error exceeds the tileset's" });
    }
    const resolver = new TilesetSourceResourceResolver('.', source);
    const traverser = new TilesetTraverser(dir, resolver, { depthFirst: true, traverseExternalTilesets: true });
    await traverser.traverse(tileset, async (traversed) => {
      const tile = traversed.asFinalTile();
      const parent = traversed.getParent();
      r.tiles++;
      r.maxDepth = Math.max(r.maxDepth, traversed.level);
      if (parent && parent.getTileset() !== traversed.getTileset()) r.externalTilesets++;
      const path = traversed.path;
      const error = tile.geometricError;
      const box = tile.boundingVolume?.box;
      if (!Number.isFinite(error) || error < 0) {
        fail('errors', { tile: path, error, why: 'not a finite, non-negative number' });
      }
      if (!isBox(box)) fail('boxes', { tile: path, why: 'its bounding volume is not a box of 12 numbers' });
      if (parent) {
        const up = parent.asFinalTile();
        r.checked.errors++;
        if (!(error <= up.geometricError)) {
          fail('errors', { tile: path, error, parentError: up.geometricError, why: "above its parent's" });
        }
        const upBox = up.boundingVolume?.box;
        if (isBox(box) && isBox(upBox)) {
          r.checked.boxes++;
          try {
            if (!boxInside(box, tile.transform, upBox, epsilon)) {
              fail('boxes', { tile: path, box, parentBox: upBox, why: "not inside its parent's" });
            }
          } catch (e) {
            fail('boxes', { tile: path, parentBox: upBox, why: `${e.message ?? e}` });
          }
        }
      }
      // An implicit tileset's root carries template URIs, not files.
      if (traversed.isImplicitTilesetRoot()) return true;
      const resolve = traversed.getResourceResolver();
      for (const content of traversed.getFinalContents()) {
        r.contents++;
        r.checked.uris++;
        const data = await resolve.resolveData(content.uri);
        if (!data) {
          fail('uris', { tile: path, uri: content.uri, why: 'does not resolve to a file' });
          continue;
        }
        const type = await ContentDataTypeRegistry.findContentDataType(new BufferedContentData(content.uri, data));
        if (type === ContentDataTypes.CONTENT_TYPE_GLB) r.glb++;
        else if (type !== ContentDataTypes.CONTENT_TYPE_TILESET) {
          fail('uris', { tile: path, uri: content.uri, why: `neither a glb nor a tileset (${type ?? 'unknown type'})` });
        }
        const contentBox = content.boundingVolume?.box;
        if (contentBox !== undefined && isBox(box)) {
          r.checked.contentBoxes++;
          if (!isBox(contentBox) || !boxInside(contentBox, undefined, box, epsilon)) {
            fail('contentBoxes', { tile: path, uri: content.uri, box: contentBox, tileBox: box, why: "not inside its tile's" });
          }
        }
      }
      return true;
    });
  } catch (e) {
    fail('read', { why: `${e.message ?? e}` });
  } finally {
    await source?.close().catch(() => {});
  }
  r.ok = Object.values(r.failed).every((n) => n === 0) && r.tiles > 0;
  return r;
}

export function summary(r) {
  const failed = Object.entries(r.failed).filter(([, n]) => n > 0).map(([k, n]) => `${n} ${k}`);
  return `3d-tiles-tools: ${r.tileset}: ${r.tiles} tiles (${r.externalTilesets} external tileset roots), ${r.glb} glb contents, depth ${r.maxDepth}; checked ${r.checked.errors} errors, ${r.checked.boxes} child boxes, ${r.checked.contentBoxes} content boxes, ${r.checked.uris} URIs: ${failed.length ? `FAILED ${failed.join(', ')}` : 'ok'}`;
}

if (import.meta.url === `file://${process.argv[1]}`) {
  const dirs = [];
  const opts = {};
  let report;
  for (let i = 2; i < process.argv.length; i++) {
    const a = process.argv[i];
    if (a === '--report') report = process.argv[++i];
    else if (a === '--epsilon') opts.epsilon = Number(process.argv[++i]);
    else dirs.push(a);
  }
  if (dirs.length === 0 || !(opts.epsilon === undefined || opts.epsilon >= 0)) {
    console.error('usage: node structure.mjs DIR [DIR ...] [--report out.json] [--epsilon E]');
    process.exit(2);
  }
  const reports = [];
  for (const dir of dirs) {
    const r = await checkStructure(dir, opts);
    reports.push(r);
    console.log(summary(r));
    for (const f of r.failures) console.log(`  ${JSON.stringify(f)}`);
  }
  if (report) {
    const { writeFileSync } = await import('node:fs');
    writeFileSync(report, JSON.stringify(reports, null, 1));
  }
  process.exit(reports.every((r) => r.ok) ? 0 : 1);
}
