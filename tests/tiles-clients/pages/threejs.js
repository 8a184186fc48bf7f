// 3d-tiles-renderer for three.js: the same pose and screen-space error,
// the same report.
import * as THREE from 'three';
import { TilesRenderer } from '3d-tiles-renderer';
import { GLTFExtensionsPlugin } from '3d-tiles-renderer/plugins';
import { MeshoptDecoder } from 'three/examples/jsm/libs/meshopt_decoder.module.js';
import { params, report, fail } from './common.js';

async function main() {
  const { pose, sse, width, height, pickAt } = params;
  const renderer = new THREE.WebGLRenderer({ antialias: false });
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
  const tiles = new TilesRenderer('/tiles/tileset.json');
  tiles.registerPlugin(new GLTFExtensionsPlugin({ meshoptDecoder: MeshoptDecoder, metadata: true }));
  tiles.errorTarget = sse;
  tiles.lruCache.minSize = 1e6; tiles.lruCache.maxSize = 1e6;
  tiles.lruCache.minBytesSize = 2 ** 31; tiles.lruCache.maxBytesSize = 2 ** 31;
  tiles.setCamera(camera);
  tiles.setResolutionFromRenderer(camera, renderer);
  scene.add(tiles.group);
  let stable = 0;
  const t0 = performance.now();
  while (stable < 10) {
    tiles.update();
    renderer.render(scene, camera);
    await new Promise((r) => setTimeout(r, 20));
    const s = tiles.stats;
    const busy = s.queued + s.downloading + s.parsing;
    stable = busy === 0 && tiles.root ? stable + 1 : 0;
    if (performance.now() - t0 > 120000) throw new Error('tiles did not load in 120 s');
  }
  let triangles = 0;
  tiles.group.traverseVisible((o) => {
    if (o.isMesh) triangles += (o.geometry.index ? o.geometry.index.count : o.geometry.attributes.position.count) / 3;
  });
  const selected = [];
  for (const t of tiles.visibleTiles) {
    if (t.content && t.content.uri) selected.push({ uri: new URL(t.content.uri, location.href).pathname, error: t.geometricError, depth: t.__depth });
  }
  // What the pixel Cesium picked at picks here.
  let pick = null;
  const candidates = [];
  if (pickAt) candidates.push([pickAt.x, pickAt.y]);
  for (let j = 0; j <= 12; j++) for (let i = 0; i <= 16; i++) candidates.push([i / 16 * width, j / 12 * height]);
  const ray = new THREE.Raycaster();
  for (const [px, py] of candidates) {
    ray.setFromCamera(new THREE.Vector2(px / width * 2 - 1, 1 - py / height * 2), camera);
    const hit = ray.intersectObject(tiles.group, true)[0];
    const mf = hit && hit.object.userData.meshFeatures;
    const sm = hit && hit.object.userData.structuralMetadata;
    if (!mf || !sm) continue;
    const ids = mf.getFeatures(hit.faceIndex, hit.barycoord);
    const info = mf.getFeatureInfo()[0];
    if (ids[0] === null || ids[0] === undefined) continue;
    const row = sm.getPropertyTableData(info.propertyTable, ids[0]);
    pick = { x: Math.round(px), y: Math.round(py), featureId: ids[0], name: row.name, objectId: row.objectId, path: row.path };
    break;
  }
  report({ tiles: selected.length, triangles, selected, pick, webgl2: renderer.capabilities.isWebGL2 });
}
main().catch(fail);
