// The blocks in the language chosen for this tablet. Blockly's own blocks take Blockly's
// translation; the runtime's blocks and the toolbox's categories take the chosen catalogue's
// block words (i18n). Applied when an editor is made: blocks read their words when built.
import * as Blockly from "blockly";
import * as BlocklyDe from "blockly/msg/de";
import * as BlocklyEn from "blockly/msg/en";
import { LANGUAGES, language } from "../i18n";

type Messages = { [key: string]: string };

// Each module is the language's messages, one export per message.
const BLOCKLY: Record<string, Messages> = {
  en: BlocklyEn as unknown as Messages,
  de: BlocklyDe as unknown as Messages,
};

// Blockly's words, shortened where a long label made a block wider than the toolbox's
// flyout on a phone.
const SHORTER: Record<string, Messages> = {
  en: {
    TEXT_TRIM_OPERATOR_BOTH: "trim both ends of",
    TEXT_TRIM_OPERATOR_LEFT: "trim the start of",
    TEXT_TRIM_OPERATOR_RIGHT: "trim the end of",
    TEXT_INDEXOF_OPERATOR_FIRST: "find first",
    TEXT_INDEXOF_OPERATOR_LAST: "find last",
  },
  de: {
    MATH_RANDOM_INT_TITLE: "Zufallszahl von %1 bis %2",
    TEXT_TRIM_OPERATOR_BOTH: "trimme beide Enden von",
    TEXT_TRIM_OPERATOR_LEFT: "trimme den Anfang von",
    TEXT_TRIM_OPERATOR_RIGHT: "trimme das Ende von",
    TEXT_INDEXOF_OPERATOR_FIRST: "finde erstes",
    TEXT_INDEXOF_OPERATOR_LAST: "finde letztes",
    TEXT_CHANGECASE_OPERATOR_UPPERCASE: "in GROSSBUCHSTABEN",
    TEXT_CHANGECASE_OPERATOR_LOWERCASE: "in kleinbuchstaben",
    TEXT_CHANGECASE_OPERATOR_TITLECASE: "Wortanfänge groß",
    LISTS_SORT_TYPE_NUMERIC: "Zahlen",
    LISTS_SORT_ORDER_ASCENDING: "aufwärts",
    LISTS_SORT_ORDER_DESCENDING: "abwärts",
    LISTS_SORT_TYPE_TEXT: "Texte",
    LISTS_SORT_TYPE_IGNORECASE: "Texte ohne Groß/klein",
  },
};

export function applyBlocklyLanguage(): void {
  Blockly.setLocale(BLOCKLY[language()] ?? BLOCKLY.en);
  Object.assign(Blockly.Msg, SHORTER[language()] ?? {});
}

type Json = Record<string, unknown>;
type Words = { message0: string; tooltip: string; options?: Record<string, Record<string, string>> };

/** The blocks' words the runtime serves, per language (the core's categories' and plugins'). */
export type RuntimeWords = Record<
  string,
  { blocks: Record<string, Words>; categories: Record<string, string> }
>;

let runtimeWords: RuntimeWords = {};

/** The blocks' words, from GET /api/programs/_blocks. */
export function useRuntimeWords(words: RuntimeWords): void {
  runtimeWords = words;
}

/** A block definition with the chosen language's words (the English one as it is). */
export function localizedBlock<T extends { type: string }>(definition: T): T {
  const words = runtimeWords[language()]?.blocks[definition.type];
  if (!words) return definition;
  // Copied by hand, not structuredClone: dynamic dropdowns hold their menu function.
  const json: Json = { ...definition, message0: words.message0, tooltip: words.tooltip };
  for (const [key, args] of Object.entries(json)) {
    if (!key.startsWith("args") || !Array.isArray(args)) continue;
    json[key] = (args as Json[]).map((field) => {
      const labels = words.options?.[String(field.name)];
      if (!labels || !Array.isArray(field.options)) return field;
      const options = (field.options as [string, string][]).map(
        ([label, value]) => [labels[value] ?? label, value],
      );
      return { ...field, options };
    });
  }
  return json as T;
}

/** The toolbox with its categories named in the chosen language. */
export function localizedToolbox(
  toolbox: Blockly.utils.toolbox.ToolboxDefinition,
): Blockly.utils.toolbox.ToolboxDefinition {
  const own = LANGUAGES[language()].blocks?.categories;
  const plugins = runtimeWords[language()]?.categories;
  if (!own && !plugins) return toolbox;
  const names = { ...plugins, ...own };
  const copy = structuredClone(toolbox) as unknown as Json;
  const rename = (items: unknown): void => {
    if (!Array.isArray(items)) return;
    for (const item of items as Json[]) {
      if (item.kind === "category" && typeof item.name === "string") {
        item.name = names[item.name] ?? item.name;
      }
      rename(item.contents);
    }
  };
  rename(copy.contents);
  return copy as unknown as Blockly.utils.toolbox.ToolboxDefinition;
}
