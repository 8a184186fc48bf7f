// What both client pages share: the pose, in the tileset's z-up frame.
export const params = JSON.parse(decodeURIComponent(location.hash.slice(1)));
export function report(r) { window.__result = r; }
export function fail(e) { window.__result = { error: String(e && e.stack || e) }; }
