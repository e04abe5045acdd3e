// Validates glTF 2.0 files with the Khronos glTF validator and prints one
// JSON report per file, as an array: `node validate-gltf.mjs A.glb [B.glb …]`.
// tests/it/export.rs runs it and reads the counts of errors, warnings,
// infos and hints and the messages. Install the validator first with
// `npm ci --prefix tests/node` (the version is pinned in package.json and
// package-lock.json). Exit status 0 when every file was validated (whatever
// it holds), 1 when one could not be read or parsed at all.
import { readFile } from "node:fs/promises";
import { basename } from "node:path";
import validator from "gltf-validator";

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error("usage: node validate-gltf.mjs FILE.glb [FILE.glb …]");
  process.exit(1);
}
const reports = [];
for (const file of files) {
  const bytes = new Uint8Array(await readFile(file));
  // A GLB holds its buffer; a reference to any other file is itself a finding.
  const report = await validator.validateBytes(bytes, {
    uri: basename(file),
    maxIssues: 1000,
    externalResourceFunction: (uri) => Promise.reject(`external resource ${uri}`),
  });
  reports.push({ file, ...report });
}
console.log(JSON.stringify(reports, null, 2));
