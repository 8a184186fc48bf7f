// 3d-tiles-renderer for three.js: the same pose and screen-space error,
// the same report.
import * as THREE from 'three';
import { TilesRenderer } from '3d-tiles-renderer';
import { GLTFExtensionsPlugin } from '3d-tiles-renderer/plugins';
import { MeshoptDecoder } from 'three/examples/jsm/libs/meshopt_decoder.module.js';
import { params, report, fail } from './common.js';

async function main() {
  const { pose, sse, width, height, grid } = params;
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setSize(width, height);
  document.getElementById('view').appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 3));
  const camera = new THREE.PerspectiveCamera(pose.fovy, width / height, pose.near, pose.far);
  camera.position.set(...pose.position);
  camera.up.set(...pose.up);
  const [x, y, z] = pose.position, [dx, dy, dz] = pose.direction;
  camera.lookAt(x + dx, y + dy, z + dz);
  camera.updateMatrixWorld();
  // Settling is timed from the tileset's first request.
  const t0 = performance.now();
  const tiles = new TilesRenderer('/tiles/tileset.json');
  tiles.registerPlugin(new GLTFExtensionsPlugin({ meshoptDecoder: MeshoptDecoder, metadata: true }));
  tiles.errorTarget = sse;
  tiles.lruCache.minSize = 1e6; tiles.lruCache.maxSize = 1e6;
  tiles.lruCache.minBytesSize = 2 ** 31; tiles.lruCache.maxBytesSize = 2 ** 31;
  tiles.setCamera(camera);
  tiles.setResolutionFromRenderer(camera, renderer);
  scene.add(tiles.group);
  // Settled: nothing queued, downloading or parsing for 10 frames
  // running; the time is that of the first of them.
  let stable = 0;
  let settled = 0;
  while (stable < 10) {
    tiles.update();
    renderer.render(scene, camera);
    await new Promise((r) => setTimeout(r, 20));
    const s = tiles.stats;
    const busy = s.queued + s.downloading + s.parsing;
    stable = busy === 0 && tiles.root ? stable + 1 : 0;
    if (stable === 1) settled = performance.now() - t0;
    if (performance.now() - t0 > 280000) throw new Error('tiles did not load in 280 s');
  }
  let triangles = 0;
  tiles.group.traverseVisible((o) => {
    if (o.isMesh) triangles += (o.geometry.index ? o.geometry.index.count : o.geometry.attributes.position.count) / 3;
  });
  const selected = [];
  for (const t of tiles.visibleTiles) {
    if (t.content && t.content.uri) selected.push({ uri: new URL(t.content.uri, location.href).pathname, error: t.geometricError });
  }
  // What each pixel of the grid picks (a ray through the pixel's centre
  // against the tiles drawn): a feature, or null.
  const ray = new THREE.Raycaster();
  const picks = grid.map(([x, y]) => {
    ray.setFromCamera(new THREE.Vector2((x + 0.5) / width * 2 - 1, 1 - (y + 0.5) / height * 2), camera);
    const hit = ray.intersectObject(tiles.group, true)[0];
    const mf = hit && hit.object.userData.meshFeatures;
    const sm = hit && hit.object.userData.structuralMetadata;
    if (!mf || !sm) return null;
    const ids = mf.getFeatures(hit.faceIndex, hit.barycoord);
    const info = mf.getFeatureInfo()[0];
    if (ids[0] === null || ids[0] === undefined) return null;
    const row = sm.getPropertyTableData(info.propertyTable, ids[0]);
    return { x, y, featureId: ids[0], name: row.name, objectId: row.objectId, path: row.path };
  });
  report({
    tiles: selected.length, triangles, selected, picks, webgl2: renderer.capabilities.isWebGL2,
    settleMs: settled,
  });
}
main().catch(fail);
