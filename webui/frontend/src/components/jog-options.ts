import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { shared } from "../styles";
import { MODE_LABEL, MODES, type Mode, STEP, STEPPINGS, type Stepping, stepLabel } from "../jog/axes";

// What the Jog panel's keys do: jog the joints, or the TCP in the base or the tool frame;
// continuously while held, or one fine or coarse step per press. Emits mode {mode} (also
// when the mode chosen is tapped again: Tool readings count afresh) and stepping
// {stepping}.
export class OpJogOptions extends LitElement {
  static properties = { mode: { type: String }, stepping: { type: String } };
  declare mode: Mode;
  declare stepping: Stepping;

  static styles = [
    shared,
    css`
      :host {
        display: block;
      }
      .segmented {
        display: flex;
        gap: 6px;
        flex-wrap: wrap;
        margin-bottom: 10px;
      }
      .segmented button[aria-pressed="true"] {
        border-color: var(--accent);
        color: var(--accent);
      }
    `,
  ];

  constructor() {
    super();
    this.mode = "joint";
    this.stepping = "continuous";
  }

  private emit(type: string, detail: object): void {
    this.dispatchEvent(new CustomEvent(type, { detail }));
  }

  render() {
    return html`<div class="segmented" role="group" aria-label=${t("jog.frame")}>
        ${MODES.map((m) => html`<button
          data-testid="mode-${m}" aria-pressed=${this.mode === m ? "true" : "false"}
          @click=${() => this.emit("mode", { mode: m })}>${t(MODE_LABEL[m])}</button>`)}
      </div>
      <div class="segmented" role="group" aria-label=${t("jog.steps")}>
        ${STEPPINGS.map((s) => html`<button
          data-testid="step-${s}" aria-pressed=${this.stepping === s ? "true" : "false"}
          @click=${() => this.emit("stepping", { stepping: s })}>${s === "continuous"
            ? t("jog.continuous") : stepLabel(STEP[s])}</button>`)}
      </div>`;
  }
}

customElements.define("op-jog-options", OpJogOptions);
