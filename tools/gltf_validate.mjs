// Validate a .glb with the Khronos glTF-Validator: `node tools/gltf_validate.mjs FILE.glb`.
// Needs `npm install gltf-validator@2` in a directory whose node_modules is on NODE_PATH or passed as
// POMC_GLTF_VALIDATOR (the path of that node_modules directory). Prints the report's issue summary as
// JSON on stdout; exit status 0 when the report has no errors, 1 otherwise, 2 on usage problems.
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";
import path from "node:path";

const file = process.argv[2];
if (!file) {
  console.error("usage: node gltf_validate.mjs FILE.glb");
  process.exit(2);
}
const modules = process.env.POMC_GLTF_VALIDATOR;
const require = createRequire(modules ? path.join(path.resolve(modules), "..", "noop.js") : import.meta.url);
const validator = require("gltf-validator");
const bytes = new Uint8Array(readFileSync(file));
const report = await validator.validateBytes(bytes, { maxIssues: 100 });
const { numErrors, numWarnings, numInfos, messages } = report.issues;
console.log(JSON.stringify({ numErrors, numWarnings, numInfos, messages: messages.slice(0, 20) }, null, 1));
process.exit(numErrors === 0 ? 0 : 1);
