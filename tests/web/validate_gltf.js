// Validates a .gltf with the Khronos glTF-Validator (npm gltf-validator),
// external resources (.bin, images) read from beside it. Prints the
// validator's issue counts and messages as JSON; exit code 0 when it reports
// no error, 1 when it does, 2 when the file cannot be read.
// Usage: node tests/web/validate_gltf.js PATH.gltf
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function main() {
  const file = process.argv[2];
  if (!file) {
    console.error('usage: node validate_gltf.js PATH.gltf');
    return 2;
  }
  let bytes;
  try {
    bytes = new Uint8Array(fs.readFileSync(file));
  } catch (error) {
    console.error(`${file}: cannot be read (${error.message})`);
    return 2;
  }
  const folder = path.dirname(file);
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.join(folder, decodeURIComponent(uri)), (error, data) => {
          if (error) reject(error.toString());
          else resolve(new Uint8Array(data));
        });
      }),
  });
  const issues = report.issues;
  console.log(JSON.stringify({
    validator: `${report.validatorVersion}`,
    numErrors: issues.numErrors,
    numWarnings: issues.numWarnings,
    numInfos: issues.numInfos,
    numHints: issues.numHints,
    messages: issues.messages.map((m) => `${m.severity} ${m.code} ${m.pointer || ''}: ${m.message}`),
    resources: (report.info && report.info.resources || []).map((r) => `${r.pointer} ${r.mimeType || ''} ${r.image ? r.image.width + 'x' + r.image.height + ' ' + r.image.format + ' ' + r.image.bits + '-bit' : ''}`),
  }, null, 2));
  return issues.numErrors === 0 ? 0 : 1;
}

main().then((code) => process.exit(code), (error) => {
  console.error(`glTF-Validator failed: ${error}`);
  process.exit(2);
});
