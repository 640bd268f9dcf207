// Every word the UI shows comes from one catalogue per language (en.ts, de.ts): a translation
// is one file. Text is looked up when it is drawn, so choosing a language redraws the page
// in it at once, on this tablet only.

import { en } from "./en";
import { de, deBlocks } from "./de";

export type StringKey = keyof typeof en;
/** A translation: every key of the English catalogue, nothing else. */
export type Catalogue = { readonly [K in StringKey]: string };

/**
 * The toolbox's categories in a language other than English, by their English names. The
 * blocks' own words come from the runtime (each category's words.json, each plugin's block
 * declarations); Blockly's own blocks come with Blockly's translation of the same language.
 */
export interface CategoryWords {
  readonly categories: Readonly<Record<string, string>>;
}

export type Language = "en" | "de";
/** The languages offered, each named in itself. */
export const LANGUAGES: Record<
  Language,
  { name: string; strings: Catalogue; blocks: CategoryWords | null }
> = {
  en: { name: "English", strings: en, blocks: null },
  de: { name: "Deutsch", strings: de, blocks: deBlocks },
};

const KEY = "op.language";

function stored(): Language {
  const chosen = localStorage.getItem(KEY) ?? "";
  return chosen in LANGUAGES ? (chosen as Language) : "en";
}

let current: Language = stored();

export function language(): Language {
  return current;
}

/** The text of a key in the chosen language, with {name} filled from params. */
export function t(key: StringKey, params?: Record<string, string | number>): string {
  const text: string = LANGUAGES[current].strings[key];
  if (!params) return text;
  return text.replace(/\{(\w+)\}/g, (whole: string, name: string) =>
    name in params ? String(params[name]) : whole,
  );
}

export function setLanguage(chosen: Language): void {
  current = chosen;
  localStorage.setItem(KEY, chosen);
  document.documentElement.lang = chosen;
  window.dispatchEvent(new Event("op-language"));
  redrawAll();
}

/** On start: the page's language as chosen, and a redraw whenever units change too. */
export function applyLanguage(): void {
  document.documentElement.lang = current;
  window.addEventListener("op-units", () => redrawAll());
}

/** Asks every component on the page, shadow roots included, to draw itself again. */
export function redrawAll(root: Document | ShadowRoot = document): void {
  for (const element of root.querySelectorAll("*")) {
    const host = element as Element & { requestUpdate?: () => void };
    if (typeof host.requestUpdate === "function") host.requestUpdate();
    if (element.shadowRoot) redrawAll(element.shadowRoot);
  }
}
