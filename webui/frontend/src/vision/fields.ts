import { html } from "lit";
import { type StringKey, t } from "../i18n";
import { lengthFromField, lengthToField, lengthUnit } from "../units";

// Number fields of the Vision panel's forms: a length shown in the chosen unit and kept in
// metres, or a plain number (degrees, counts); a field left empty or not a number keeps
// its value.

export function lengthField(
  key: StringKey,
  testid: string,
  metres: number,
  set: (metres: number) => void,
) {
  return html`<label>${t(key)} (${lengthUnit()})
    <input type="number" step="any" inputmode="decimal" data-testid=${testid}
      .value=${String(lengthToField(metres))}
      @change=${(e: Event) => {
        const raw = (e.target as HTMLInputElement).value;
        if (raw.trim() !== "" && Number.isFinite(Number(raw))) set(lengthFromField(Number(raw)));
      }} /></label>`;
}

export function numberField(
  label: string,
  testid: string,
  value: number,
  set: (value: number) => void,
  step = "any",
) {
  return html`<label>${label}
    <input type="number" step=${step} inputmode="decimal" data-testid=${testid}
      .value=${String(value)}
      @change=${(e: Event) => {
        const raw = (e.target as HTMLInputElement).value;
        if (raw.trim() !== "" && Number.isFinite(Number(raw))) set(Number(raw));
      }} /></label>`;
}
