// CesiumJS (@cesium/engine): loads the tileset, refines it from the pose
// to the asked screen-space error, reports the tiles and triangles it
// selected and what a pixel picks.
import {
  CesiumWidget, Cesium3DTileset, Cartesian2, Cartesian3, PerspectiveFrustum,
  Cesium3DTileFeature, Math as CesiumMath,
} from '@cesium/engine';
import { params, report, fail } from './common.js';

async function main() {
  const { pose, sse, width, height } = params;
  const widget = new CesiumWidget('view', {
    globe: false, skyBox: false, skyAtmosphere: false, baseLayer: false,
    useDefaultRenderLoop: false, shadows: false, scene3DOnly: true,
    contextOptions: { webgl: { preserveDrawingBuffer: true } },
  });
  const scene = widget.scene;
  const tileset = await Cesium3DTileset.fromUrl('/tiles/tileset.json', {
    maximumScreenSpaceError: sse,
    dynamicScreenSpaceError: false,
    foveatedScreenSpaceError: false,
    progressiveResolutionHeightFraction: 0,
    cacheBytes: 2 ** 31,
    maximumCacheOverflowBytes: 2 ** 31,
  });
  scene.primitives.add(tileset);
  const camera = scene.camera;
  const frustum = new PerspectiveFrustum();
  // Cesium's fov is the wider angle: horizontal on a wide view.
  const fovy = CesiumMath.toRadians(pose.fovy);
  frustum.fov = width > height ? 2 * Math.atan(Math.tan(fovy / 2) * width / height) : fovy;
  frustum.aspectRatio = width / height;
  frustum.near = pose.near;
  frustum.far = pose.far;
  camera.frustum = frustum;
  camera.setView({
    destination: new Cartesian3(...pose.position),
    orientation: { direction: new Cartesian3(...pose.direction), up: new Cartesian3(...pose.up) },
  });
  let stable = 0;
  const t0 = performance.now();
  while (stable < 5) {
    widget.resize();
    widget.render();
    await new Promise((r) => setTimeout(r, 20));
    stable = tileset.tilesLoaded ? stable + 1 : 0;
    if (performance.now() - t0 > 120000) throw new Error('tiles did not load in 120 s');
  }
  widget.render();
  const st = tileset.statistics;
  const selected = [];
  for (const t of tileset._selectedTiles ?? []) {
    if (t.content && t.content.url) selected.push({ uri: new URL(t.content.url, location.href).pathname, error: t.geometricError, depth: t._depth });
  }
  // The first pixel on a grid, from the centre out, that picks a feature.
  let pick = null;
  const canvas = scene.canvas;
  const cw = canvas.clientWidth, ch = canvas.clientHeight;
  const points = [];
  for (let j = 0; j <= 12; j++) for (let i = 0; i <= 16; i++) points.push([i / 16, j / 12]);
  points.sort((a, b) => Math.hypot(a[0] - 0.5, a[1] - 0.5) - Math.hypot(b[0] - 0.5, b[1] - 0.5));
  for (const [u, v] of points) {
    const p = new Cartesian2(Math.min(cw - 1, Math.round(u * cw)), Math.min(ch - 1, Math.round(v * ch)));
    const f = scene.pick(p);
    if (f instanceof Cesium3DTileFeature && f.getProperty('name') !== undefined) {
      pick = { x: p.x, y: p.y, featureId: f.featureId, name: f.getProperty('name'), objectId: f.getProperty('objectId'), path: f.getProperty('path') };
      break;
    }
  }
  report({
    tiles: st.selected, triangles: st.numberOfTrianglesSelected, loaded: st.numberOfTilesWithContentReady,
    features: st.numberOfFeaturesSelected, selected, pick, webgl2: scene.context.webgl2,
  });
}
main().catch(fail);
