// Starts gigawalk's wasm module on the page's canvas with the scene that
// config.json (written by `gigawalk web`) or ?scene=URL names, and shows
// any failure on the page. window.gigawalkStats() is what tests read.
// ?budget=MB bounds the geometry kept on the device, ?pixel_error=P the
// error levels are chosen by; #view=... (V in the page) is a saved view.
import init, {
  start, stats, load_path, show_pose, set_mode, set_pixel_error, set_hud, pick, click, find,
  view_link, view_json, show_view, read_frame,
} from './gigawalk_web.js';

const status = document.getElementById('status');
const canvas = document.getElementById('view');
let failure = null;

// What tests and scripts drive: a camera path's poses, the mode, the
// pixel error, the HUD, pick and find, and view links (see
// crates/web/src/page.rs).
window.gigawalk = {
  loadPath: load_path, showPose: show_pose, setMode: set_mode, setPixelError: set_pixel_error,
  setHud: set_hud, pick: async (x, y) => JSON.parse(await pick(x, y)), click, find,
  viewLink: view_link, view: () => JSON.parse(view_json()), showView: show_view,
  readFrame: read_frame,
};

window.gigawalkStats = () => {
  if (failure) return { state: 'error', error: failure };
  try { return JSON.parse(stats()); } catch (e) { return { state: 'loading' }; }
};

function showError(message) {
  failure = String(message);
  status.textContent = failure;
  status.className = 'error';
}

// ?size=WxH fixes the canvas in device pixels (benchmarks, tests);
// otherwise it follows the window.
function fit() {
  const fixed = /^(\d+)x(\d+)$/.exec(new URLSearchParams(location.search).get('size') || '');
  if (fixed) {
    canvas.width = Number(fixed[1]);
    canvas.height = Number(fixed[2]);
    canvas.style.width = `${canvas.width / (window.devicePixelRatio || 1)}px`;
    canvas.style.height = `${canvas.height / (window.devicePixelRatio || 1)}px`;
    return;
  }
  const r = window.devicePixelRatio || 1;
  canvas.width = Math.max(1, Math.floor(canvas.clientWidth * r));
  canvas.height = Math.max(1, Math.floor(canvas.clientHeight * r));
}

async function sceneUrl() {
  const asked = new URLSearchParams(location.search).get('scene');
  if (asked) return asked;
  try {
    const r = await fetch('config.json', { cache: 'no-cache' });
    if (r.ok) {
      const c = await r.json();
      if (typeof c.scene === 'string') return c.scene;
    }
  } catch (e) { /* no config: the default below */ }
  return 'scene.gwk';
}

try {
  await init();
  const url = new URL(await sceneUrl(), location.href).href;
  fit();
  window.addEventListener('resize', fit);
  status.textContent = `Opening ${url}...`;
  await start(canvas, url);
  status.textContent = '';
  canvas.focus();
} catch (e) {
  const s = window.gigawalkStats();
  showError(s.error || (e && e.message) || String(e));
}
