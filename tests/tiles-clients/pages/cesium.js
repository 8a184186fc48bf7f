// CesiumJS (@cesium/engine): loads the tileset, refines it from the pose
// to the asked screen-space error, reports the tiles and triangles it
// selected and what a pixel picks.
import {
  CesiumWidget, Cesium3DTileset, Cartesian2, Cartesian3, PerspectiveFrustum,
  Cesium3DTileFeature, Math as CesiumMath,
} from '@cesium/engine';
import { params, report, fail } from './common.js';

async function main() {
  const { pose, sse, width, height, grid } = params;
  const widget = new CesiumWidget('view', {
    globe: false, skyBox: false, skyAtmosphere: false, baseLayer: false,
    useDefaultRenderLoop: false, shadows: false, scene3DOnly: true,
    contextOptions: { webgl: { preserveDrawingBuffer: true } },
  });
  const scene = widget.scene;
  // Settling is timed from the tileset's first request.
  const t0 = performance.now();
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
  // The pose as it is: position, direction and up in the tileset's frame
  // (setView would go through heading, pitch and roll in the east-north-up
  // frame of the ellipsoid point below the eye, which is not this frame).
  camera.position = new Cartesian3(...pose.position);
  camera.direction = Cartesian3.normalize(new Cartesian3(...pose.direction), new Cartesian3());
  camera.up = Cartesian3.normalize(new Cartesian3(...pose.up), new Cartesian3());
  camera.right = Cartesian3.cross(camera.direction, camera.up, new Cartesian3());
  // Settled: no tile pending for 5 frames running; the time is that of
  // the first of them.
  let stable = 0;
  let settled = 0;
  while (stable < 5) {
    widget.resize();
    widget.render();
    await new Promise((r) => setTimeout(r, 20));
    stable = tileset.tilesLoaded ? stable + 1 : 0;
    if (stable === 1) settled = performance.now() - t0;
    if (performance.now() - t0 > 280000) throw new Error('tiles did not load in 280 s');
  }
  widget.render();
  // Statistics are counted again by every pass, picks included: read
  // them now, after the last render.
  const st = { ...tileset.statistics };
  const selected = [];
  for (const t of tileset._selectedTiles ?? []) {
    if (t.content && t.content.url) selected.push({ uri: new URL(t.content.url, location.href).pathname, error: t.geometricError });
  }
  // What each pixel of the grid picks (at the pixel's centre): a feature
  // (its ID, the object's index and name), or null (nothing, or a tile
  // without features).
  const picks = grid.map(([x, y]) => {
    const f = scene.pick(new Cartesian2(x + 0.5, y + 0.5), 1, 1);
    if (!(f instanceof Cesium3DTileFeature) || f.getProperty('name') === undefined) return null;
    return { x, y, featureId: f.featureId, name: f.getProperty('name'), objectId: f.getProperty('objectId'), path: f.getProperty('path') };
  });
  report({
    tiles: st.selected, triangles: st.numberOfTrianglesSelected, loaded: st.numberOfTilesWithContentReady,
    features: st.numberOfFeaturesSelected, selected, picks, webgl2: scene.context.webgl2,
    settleMs: settled,
  });
}
main().catch(fail);
