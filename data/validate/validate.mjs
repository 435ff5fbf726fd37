// Validates glTF 2.0 assets (.glb / .gltf) with the Khronos glTF validator.
//
// Usage: node validate.mjs [FILE ...]
//   With no arguments, validates every .glb and .gltf file in data/ (the
//   parent of this directory).
// Prints one summary line per file (errors / warnings / infos / hints), the
// messages of every error and warning, and exits with status 1 if any file has
// an error (or could not be read), 0 otherwise.

import { readFile, readdir } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import validator from 'gltf-validator';

const SEVERITY = ['error', 'warning', 'info', 'hint'];

async function defaultFiles() {
  const dataDir = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
  const names = (await readdir(dataDir)).filter((n) => /\.(glb|gltf)$/i.test(n)).sort();
  return names.map((n) => path.join(dataDir, n));
}

async function validateFile(file) {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    format: file.toLowerCase().endsWith('.glb') ? 'glb' : 'gltf',
    maxIssues: 0, // no limit
    // External buffers / images of a .gltf, resolved next to the file.
    externalResourceFunction: (uri) =>
      readFile(path.join(path.dirname(file), decodeURIComponent(uri))).then(
        (b) => new Uint8Array(b),
      ),
  });
  const i = report.issues;
  console.log(
    `${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ` +
      `${i.numInfos} infos, ${i.numHints} hints`,
  );
  for (const m of i.messages) {
    if (m.severity <= 1) {
      console.log(`  ${SEVERITY[m.severity]} ${m.code} at ${m.pointer ?? '-'}: ${m.message}`);
    }
  }
  return i.numErrors;
}

const args = process.argv.slice(2);
const files = args.length > 0 ? args : await defaultFiles();
if (files.length === 0) {
  console.error('validate.mjs: no .glb/.gltf files given or found');
  process.exit(1);
}
let failed = 0;
for (const file of files) {
  try {
    if ((await validateFile(file)) > 0) failed += 1;
  } catch (e) {
    console.log(`${file}: could not be validated: ${e?.message ?? e}`);
    failed += 1;
  }
}
if (failed > 0) {
  console.log(`${failed} of ${files.length} file(s) failed validation`);
  process.exit(1);
}
console.log(`all ${files.length} file(s) valid`);
