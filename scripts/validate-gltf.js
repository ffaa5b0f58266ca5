// Validates a .glb or .gltf with the Khronos glTF Validator (npm `gltf-validator`, installed by
// scripts/test.sh into tools/npm). Prints the issue counts as JSON; exits 1 when there are errors.
//
//   node scripts/validate-gltf.js FILE
const fs = require('fs');
const path = require('path');
const validator = require(path.join(__dirname, '..', 'tools', 'npm', 'node_modules', 'gltf-validator'));
const file = process.argv[2];
const beside = (uri) => new Promise((resolve, reject) => {
  try {
    resolve(new Uint8Array(fs.readFileSync(path.join(path.dirname(file), decodeURIComponent(uri)))));
  } catch (e) {
    reject(e.toString());
  }
});
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
  uri: path.basename(file),
  externalResourceFunction: beside,
}).then((report) => {
  const i = report.issues;
  console.log(JSON.stringify({ errors: i.numErrors, warnings: i.numWarnings, infos: i.numInfos,
    messages: i.messages.filter((m) => m.severity <= 1).slice(0, 10) }));
  process.exit(i.numErrors > 0 ? 1 : 0);
}, (e) => {
  console.error(String(e));
  process.exit(2);
});
