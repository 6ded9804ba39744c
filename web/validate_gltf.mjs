// Validates a .gltf with the Khronos glTF-Validator (npm gltf-validator), resolving its .bin and
// images beside it. Prints the validator's issue counts and messages as JSON; exit 1 on errors.
// Usage: node validate_gltf.mjs FILE.gltf
import validator from 'gltf-validator';
import { readFileSync } from 'node:fs';
import { dirname, join } from 'node:path';

const path = process.argv[2];
const report = await validator.validateBytes(new Uint8Array(readFileSync(path)), {
  uri: path,
  externalResourceFunction: (uri) =>
    Promise.resolve(new Uint8Array(readFileSync(join(dirname(path), decodeURIComponent(uri))))),
});
const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
console.log(JSON.stringify({ numErrors, numWarnings, numInfos, numHints,
  messages: messages.map((m) => `${m.code} ${m.pointer ?? ''}: ${m.message}`),
  extensionsUsed: report.info ? report.info.extensionsUsed : [] }, null, 2));
process.exit(numErrors > 0 ? 1 : 0);
