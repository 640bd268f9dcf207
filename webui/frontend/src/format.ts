// How values read to people; lengths and angles are in units.ts.

import { html, type TemplateResult } from "lit";
import { t } from "./i18n";
import type { ConnectionStatus } from "./types";

export function modeLabel(mode: string): string {
  switch (mode) {
    case "manual_reduced_speed":
      return t("app.mode.manual");
    case "manual_full_speed":
      return t("app.mode.manual_full_speed");
    case "auto":
      return t("app.mode.auto");
    default:
      return t("app.mode.unknown");
  }
}

/** A device's link status in a sentence or a tooltip ("connected"). */
export function linkLabel(status: ConnectionStatus): string {
  switch (status) {
    case "connecting":
      return t("app.link.connecting");
    case "connected":
      return t("app.link.connected");
    case "stale":
      return t("app.link.stale");
    case "disconnected":
      return t("app.link.disconnected");
  }
}

/** A translated sentence whose {placeholder} is shown in bold, the first time it occurs (the
 * word order is the translation's, so the bold part cannot be cut out of it beforehand). */
export function withBold(text: string, placeholder: string, value: string): TemplateResult {
  const [before, ...after] = text.split(`{${placeholder}}`);
  if (after.length === 0) return html`${text}`;
  return html`${before}<strong>${value}</strong>${after.join(value)}`;
}

export function suggestLocalName(kind: string, taken: Set<string>): string {
  const base = /^[a-z]+$/.test(kind) ? kind : "device";
  if (!taken.has(base)) return base;
  for (let i = 2; ; i++) {
    if (!taken.has(`${base}${i}`)) return `${base}${i}`;
  }
}

export const LOCAL_NAME = /^[a-z][a-z0-9_]{0,31}$/;
