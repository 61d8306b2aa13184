#!/usr/bin/env node
// Validates a glTF binary (.glb) with the Khronos glTF validator and prints, as JSON, the
// counts of errors, warnings and infos and every error and warning. Exit status: 0 without
// errors, 1 with errors, 2 when the file cannot be read or parsed at all.
//
//     node tools/validate/validate.js FILE.glb
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function main() {
  const file = process.argv[2];
  if (!file) {
    console.error('usage: validate.js FILE.glb');
    return 2;
  }
  let bytes;
  try {
    bytes = new Uint8Array(fs.readFileSync(file));
  } catch (e) {
    console.error(`${file}: cannot read: ${e.message}`);
    return 2;
  }
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 0,  // no limit
    // A .glb from weft holds all its data; any external reference is itself a fault.
    externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
  });
  const issues = report.issues;
  const severityName = ['error', 'warning', 'info', 'hint'];
  const listed = issues.messages
    .filter((m) => m.severity <= 1)
    .map((m) => ({severity: severityName[m.severity], code: m.code, message: m.message, pointer: m.pointer}));
  console.log(JSON.stringify({
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    messages: listed,
  }, null, 2));
  return issues.numErrors > 0 ? 1 : 0;
}

main().then((code) => process.exit(code), (e) => {
  console.error(`validate.js: ${e && e.message ? e.message : e}`);
  process.exit(2);
});
