import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
import type { AddedDevice, InputState } from "../types";

// The 3D mouse on the Jog panel: which mouse, on or off, how sensitive, and a live readout
// of each of its axes with what that axis drives right now (a joint in Joints mode, a
// direction of the base or tool frame otherwise), so "lift" never surprises.

const MOTIONS = [
  "jog.mouse.slide_right",
  "jog.mouse.slide_forward",
  "jog.mouse.lift",
  "jog.mouse.tilt_forward",
  "jog.mouse.tilt_right",
  "jog.mouse.twist_left",
] as const;
const CARTESIAN = ["X", "Y", "Z", "Rx", "Ry", "Rz"];

export class OpMouseCard extends LitElement {
  static properties = {
    mice: { attribute: false },
    device: { type: String },
    on: { type: Boolean },
    disabled: { type: Boolean },
    mode: { type: String },
    sensitivity: { type: Number },
    input: { attribute: false },
    note: { type: String },
  };
  declare mice: AddedDevice[];
  declare device: string;
  declare on: boolean;
  declare disabled: boolean;
  declare mode: "joint" | "base" | "tool";
  declare sensitivity: number;
  declare input: InputState | null;
  declare note: string; // waiting for the mouse, or why it went off by itself

  static styles = [
    shared,
    css`
      .row {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
        align-items: center;
      }
      select {
        min-height: 56px;
        font: inherit;
        background: var(--bg);
        color: var(--text);
        border: 2px solid var(--line);
        border-radius: 10px;
        padding: 0 12px;
      }
      label.sensitivity {
        display: flex;
        align-items: center;
        gap: 8px;
        flex: 1 1 220px;
      }
      label.sensitivity input {
        flex: 1;
        min-height: 48px;
        accent-color: var(--accent);
      }
      table {
        width: 100%;
        border-collapse: collapse;
        margin-top: 8px;
        font-variant-numeric: tabular-nums;
      }
      td {
        padding: 4px 6px;
        border-top: 1px solid var(--line);
      }
      td.bar {
        width: 40%;
      }
      .track {
        position: relative;
        height: 12px;
        border-radius: 6px;
        background: var(--raised);
      }
      .note {
        color: var(--warn);
        font-weight: 600;
      }
      .fill {
        position: absolute;
        top: 0;
        bottom: 0;
        background: var(--accent);
        border-radius: 6px;
      }
    `,
  ];

  constructor() {
    super();
    this.mice = [];
    this.device = "";
    this.on = false;
    this.disabled = false;
    this.mode = "joint";
    this.sensitivity = 100;
    this.input = null;
    this.note = "";
  }

  private emit(name: string, detail: unknown): void {
    this.dispatchEvent(new CustomEvent(name, { detail, bubbles: true, composed: true }));
  }

  private drives(axis: number): string {
    if (this.mode === "joint") return t("jog.joint_short", { number: axis + 1 });
    const key = this.mode === "tool" ? "jog.mouse.drives_tool" : "jog.mouse.drives_base";
    return t(key, { axis: CARTESIAN[axis] });
  }

  private readout() {
    const axes = this.input?.connected ? this.input.axes : null;
    return html`<table data-testid="mouse-axes">
      ${MOTIONS.map((motion, i) => {
        const value = axes ? axes[i] : 0;
        const left = value < 0 ? 50 + value * 50 : 50;
        return html`<tr data-axis=${i}>
          <td>${t(motion)}</td>
          <td data-testid="mouse-drives"><strong>${this.drives(i)}</strong></td>
          <td class="bar"><div class="track"><div class="fill"
            style="left:${left}%;width:${Math.abs(value) * 50}%"></div></div></td>
          <td data-testid="mouse-value">${axes ? `${Math.round(value * 100)} %` : "–"}</td>
        </tr>`;
      })}
    </table>`;
  }

  render() {
    const note = this.note
      ? html`<p class="note" role="status" data-testid="mouse-note">${this.note}</p>`
      : "";
    if (!this.mice.length) return html`${note}<p class="muted">${t("jog.mouse.none")}</p>`;
    const device = this.device || this.mice[0].local_name;
    return html`<div class="row">
        <select aria-label=${t("jog.mouse.title")} .value=${device}
          @change=${(e: Event) => this.emit("mouse-device", (e.target as HTMLSelectElement).value)}>
          ${this.mice.map((m) => html`<option value=${m.local_name}>${m.local_name}</option>`)}
        </select>
        <button data-testid="mouse-toggle" class=${this.on ? "primary" : ""}
          ${makes(request("WS", "/api/jog/ws"))}
          ?disabled=${this.disabled && !this.on} @click=${() => this.emit("mouse-toggle", !this.on)}>
          ${this.on ? t("jog.mouse.turn_off") : t("jog.mouse.use")}</button>
        <label class="sensitivity">
          <span>${t("jog.mouse.sensitivity")}</span>
          <input type="range" min="10" max="100" step="5" .value=${String(this.sensitivity)}
            data-testid="mouse-sensitivity" aria-label=${t("jog.mouse.sensitivity_label")}
            @change=${(e: Event) =>
              this.emit("mouse-sensitivity", Number((e.target as HTMLInputElement).value))} />
          <strong>${this.sensitivity} %</strong>
        </label>
      </div>
      ${note}
      ${this.readout()}
      <p class="muted">${t("jog.mouse.buttons_hint")}</p>`;
  }
}

customElements.define("op-mouse-card", OpMouseCard);
