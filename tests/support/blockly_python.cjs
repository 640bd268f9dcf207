// Blockly's own Python for each workspace, the oracle of tests/unit/test_blockly_oracle.py.
//
//   node blockly_python.cjs <the UI's package directory>  < workspaces.json  > results.json
//
// Reads a JSON list of workspaces (Blockly's JSON serialization), loads each into a headless
// Blockly workspace with the UI's own `blockly` package and writes a JSON list with, for each,
// {python, saved}: the code of Blockly's `pythonGenerator` and the workspace as Blockly saves
// it once loaded (what the UI would send), or {error} when Blockly refuses it.
"use strict";

const fs = require("node:fs");
const path = require("node:path");
const { createRequire } = require("node:module");

const ui = process.argv[2];
if (!ui) {
  process.stderr.write("usage: node blockly_python.cjs <UI package directory>\n");
  process.exit(2);
}
// Resolved as the UI resolves it: from its package.json, through its node_modules.
const load = createRequire(path.join(path.resolve(ui), "package.json"));
const Blockly = load("blockly");
const { pythonGenerator } = load("blockly/python");

// Nothing but the answer on stdout.
console.log = console.error;

const results = [];
for (const state of JSON.parse(fs.readFileSync(0, "utf8"))) {
  const workspace = new Blockly.Workspace();
  try {
    Blockly.serialization.workspaces.load(state, workspace);
    results.push({
      python: pythonGenerator.workspaceToCode(workspace),
      saved: Blockly.serialization.workspaces.save(workspace),
    });
  } catch (error) {
    results.push({ error: String(error && error.stack ? error.stack : error) });
  } finally {
    workspace.dispose();
  }
}
process.stdout.write(JSON.stringify(results));
