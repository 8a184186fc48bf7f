// Runs the Khronos glTF validator over every .glb under a tileset
// directory: prints each file with errors and a total, exits non-zero when
// any content has an error.
import { readFileSync, readdirSync, statSync } from 'node:fs';
import { join } from 'node:path';
import validator from 'gltf-validator';

function* glbs(dir) {
  for (const name of readdirSync(dir)) {
    const p = join(dir, name);
    if (statSync(p).isDirectory()) yield* glbs(p);
    else if (name.endsWith('.glb')) yield p;
  }
}

export async function validateAll(dir, { limit = Infinity } = {}) {
  let files = 0, errors = 0, warnings = 0;
  const messages = new Map();
  for (const file of glbs(dir)) {
    if (files >= limit) break;
    files++;
    const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), {
      uri: file,
      maxIssues: 50,
    });
    const n = report.issues.numErrors;
    errors += n;
    warnings += report.issues.numWarnings;
    for (const m of report.issues.messages) {
      if (m.severity > 1) continue; // errors (0) and warnings (1)
      const key = `${m.severity === 0 ? 'error' : 'warning'} ${m.code}: ${m.message.replace(/\d+/g, 'N')}`;
      if (!messages.has(key)) messages.set(key, `${file} ${m.pointer ?? ''}`);
    }
  }
  return { files, errors, warnings, messages: [...messages].map(([k, v]) => `${k} (first: ${v})`) };
}

if (import.meta.url === `file://${process.argv[1]}`) {
  const dir = process.argv[2];
  const r = await validateAll(dir);
  for (const m of r.messages) console.log(m);
  console.log(`validator: ${r.files} contents, ${r.errors} errors, ${r.warnings} warnings`);
  process.exit(r.errors > 0 || r.files === 0 ? 1 : 0);
}
