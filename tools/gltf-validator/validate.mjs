// Validates glTF/GLB files with the Khronos glTF validator; prints one JSON summary per file and
// exits 1 if any file has errors (warnings are reported, not fatal).
//   node tools/gltf-validator/validate.mjs out.glb [out.gltf …]
import { readFile } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

let failed = false;
for (const file of process.argv.slice(2)) {
  const data = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(data, {
    uri: path.basename(file),
    externalResourceFunction: (uri) =>
      readFile(path.join(path.dirname(file), decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
  });
  const { numErrors, numWarnings, numInfos } = report.issues;
  console.log(JSON.stringify({ file, numErrors, numWarnings, numInfos, messages: report.issues.messages.slice(0, 10) }));
  if (numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
