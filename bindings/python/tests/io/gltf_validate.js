// The Khronos glTF validator (npm package gltf-validator) on the files named on the command
// line: prints one JSON line per file, {"file": ..., "issues": {numErrors, numWarnings,
// numInfos, numHints, messages: [...]}}. Used by test_gltf.py; the package is found in the
// folder $GLTF_VALIDATOR (scripts/setup.sh installs it into .venv/node_modules/gltf-validator).
"use strict";
const fs = require("fs");
const path = require("path");
const validator = require(process.env.GLTF_VALIDATOR || "gltf-validator");

async function main() {
  for (const file of process.argv.slice(2)) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 200,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)),
                    (err, data) => (err ? reject(err.toString()) : resolve(data)));
      }),
    });
    console.log(JSON.stringify({ file, issues: report.issues, info: report.info }));
  }
}

main().catch((e) => { console.error(String(e)); process.exit(1); });
