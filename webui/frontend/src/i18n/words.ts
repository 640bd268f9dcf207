// What the runtime says (refusals, a program's problems and errors) in the chosen language.
// Beside its English text the server sends words: a stable code and the values it names
// (runtime/kit/words.py). A code this catalogue has is shown as `server.<code>`, its params
// filled in (a param may be words of its own: a role, an input's name); any other is shown
// in the server's English.

import { LANGUAGES, language, t, type StringKey } from "./index";

// As the runtime's answers have them (its Words model): a param is text, a number, or words.
export interface Words {
  code: string;
  params?: Record<string, unknown>;
}

function isWords(value: unknown): value is Words {
  return typeof value === "object" && value !== null && typeof (value as Words).code === "string";
}

const MAX_DEPTH = 4;

function say(words: Words, depth: number): string | null {
  const key = `server.${words.code}`;
  if (depth > MAX_DEPTH || !Object.hasOwn(LANGUAGES[language()].strings, key)) return null;
  const values: Record<string, string | number> = {};
  for (const [name, value] of Object.entries(words.params ?? {})) {
    if (typeof value === "object" && value !== null) {
      const nested = isWords(value) ? say(value, depth + 1) : null;
      if (nested === null) return null;
      values[name] = nested;
    } else {
      values[name] = typeof value === "number" ? value.toLocaleString(language()) : String(value);
    }
  }
  return t(key as StringKey, values);
}

/** The server's text in the chosen language: its words if this catalogue knows them, else the
 * English `message` as it came. */
export function worded(message: string, words?: Words | null): string {
  if (!words || typeof words.code !== "string") return message;
  return say(words, 0) ?? message;
}
