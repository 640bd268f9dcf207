// The runtime's blocks in Blockly: definitions and toolbox from GET /api/programs/_blocks, and
// the dropdowns that list what the system has (robots, waypoints, I/O names, detectors).

import * as Blockly from "blockly";
import { type StringKey, t } from "../i18n";
import { feed } from "../live";
import { localizedBlock, type RuntimeWords, useRuntimeWords } from "./blockly-words";

type BlockJson = { type: string } & Record<string, unknown>;
type FieldJson = { type?: string; options?: unknown; op_options?: string } & Record<
  string,
  unknown
>;

export interface BlockCatalog {
  definitions: Record<string, BlockJson[]>;
  toolbox: Blockly.utils.toolbox.ToolboxDefinition;
  /** The plugins' block and category words, per language. */
  words?: RuntimeWords;
}

export type ChoiceKind =
  | "robots"
  | "waypoints"
  | "inputs"
  | "outputs"
  | "analogs"
  | "analog_outputs"
  | "detectors";

const EMPTY_LABEL: Record<ChoiceKind, StringKey> = {
  robots: "program.choices.no_robots",
  waypoints: "program.choices.no_waypoints",
  inputs: "program.choices.no_inputs",
  outputs: "program.choices.no_outputs",
  analogs: "program.choices.no_analogs",
  analog_outputs: "program.choices.no_analog_outputs",
  detectors: "program.choices.no_detectors",
};

/** What the runtime has now; the panel keeps these current. */
export const choices: Record<ChoiceKind, string[]> = {
  robots: [],
  waypoints: [],
  inputs: [],
  outputs: [],
  analogs: [],
  analog_outputs: [],
  detectors: [],
};

// Names used by loaded programs stay selectable even when the system no longer has them:
// a program naming a removed robot loads as it was saved, and its run reports the name.
const used: Record<ChoiceKind, Set<string>> = {
  robots: new Set(),
  waypoints: new Set(),
  inputs: new Set(),
  outputs: new Set(),
  analogs: new Set(),
  analog_outputs: new Set(),
  detectors: new Set(),
};

const dynamicFields = new Map<string, ChoiceKind>(); // "<block type>/<field name>" -> kind

/** "devices:<kind>": the added devices of a kind (a plugin's blocks name theirs so). */
function deviceMenu(kind: string): Blockly.MenuGeneratorFunction {
  return function (this: Blockly.FieldDropdown): Blockly.MenuOption[] {
    const names = new Set(feed.devices.filter((d) => d.kind === kind).map((d) => d.local_name));
    const current = this.getValue();
    if (current) names.add(current);
    if (names.size === 0) return [[t("program.choices.no_devices"), ""]];
    return [...names].sort().map((name) => [name, name]);
  };
}

function menu(kind: ChoiceKind): Blockly.MenuGeneratorFunction {
  return function (this: Blockly.FieldDropdown): Blockly.MenuOption[] {
    const names = new Set([...choices[kind], ...used[kind]]);
    const current = this.getValue();
    if (current) names.add(current);
    if (names.size === 0) return [[t(EMPTY_LABEL[kind]), ""]];
    return [...names].sort().map((name) => [name, name]);
  };
}

let defined = false;

/** Registers the project's blocks with Blockly (once; the standard ones come with it). */
export function defineBlocks(catalog: BlockCatalog): void {
  if (defined) return;
  useRuntimeWords(catalog.words ?? {});
  for (const definition of Object.values(catalog.definitions).flat()) {
    const json = structuredClone(definition);
    for (const [key, args] of Object.entries(json)) {
      if (!key.startsWith("args") || !Array.isArray(args)) continue;
      for (const field of args as FieldJson[]) {
        const choice = field.op_options;
        if (choice === undefined) continue;
        if (choice.startsWith("devices:")) {
          field.options = deviceMenu(choice.slice("devices:".length));
        } else if (choice in choices) {
          dynamicFields.set(`${json.type}/${String(field.name)}`, choice as ChoiceKind);
          field.options = menu(choice as ChoiceKind);
        }
        delete field.op_options;
      }
    }
    Blockly.Blocks[json.type] = {
      init(this: Blockly.Block) {
        this.jsonInit(localizedBlock(json)); // in the language chosen when it is made
      },
    };
  }
  defined = true;
}

/** Before loading a saved workspace: its robot, waypoint and I/O names become options. */
export function rememberNames(state: unknown): void {
  const visit = (node: unknown): void => {
    if (Array.isArray(node)) {
      node.forEach(visit);
      return;
    }
    if (node === null || typeof node !== "object") return;
    const block = node as { type?: unknown; fields?: Record<string, unknown> };
    if (typeof block.type === "string" && block.fields) {
      for (const [field, value] of Object.entries(block.fields)) {
        const kind = dynamicFields.get(`${block.type}/${field}`);
        if (kind && typeof value === "string" && value) used[kind].add(value);
      }
    }
    Object.values(node).forEach(visit);
  };
  visit(state);
}
