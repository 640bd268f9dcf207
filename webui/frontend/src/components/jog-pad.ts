import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
import "./hold-button";

export interface JogAxis {
  key: string; // "0".."6" for joints, "x".."rz" for Cartesian
  label: string;
  value: string; // shown between the buttons
}

// Rows of [−] value [+]. Emits jog-hold {axis, direction} and jog-release.
export class OpJogPad extends LitElement {
  static properties = {
    axes: { attribute: false },
    disabled: { type: Boolean },
    why: { type: String },
  };
  declare axes: JogAxis[];
  declare disabled: boolean;
  declare why: string; // why the buttons are disabled, said on a touch

  static styles = [
    shared,
    css`
      .row {
        display: grid;
        grid-template-columns: 64px 1fr minmax(96px, 1.2fr) 1fr;
        gap: 8px;
        align-items: center;
        margin-bottom: 8px;
      }
      .name {
        font-weight: 700;
        font-size: 18px;
      }
      .value {
        text-align: center;
        font-variant-numeric: tabular-nums;
        background: var(--bg);
        border-radius: 8px;
        padding: 14px 6px;
      }
    `,
  ];

  constructor() {
    super();
    this.axes = [];
    this.disabled = false;
    this.why = "";
  }

  private emit(name: string, axis: string, direction: number) {
    this.dispatchEvent(
      new CustomEvent(name, { detail: { axis, direction }, bubbles: true, composed: true }),
    );
  }

  render() {
    const jogs = makes(request("WS", "/api/jog/ws"));
    return html`${this.axes.map(
      (a) => html`<div class="row" data-testid="jog-row" data-axis=${a.key}>
        <span class="name">${a.label}</span>
        <op-hold-button
          data-testid="jog-minus"
          ${jogs}
          label="−"
          aria-label=${t("jog.axis_minus", { axis: a.label })}
          ?disabled=${this.disabled}
          why=${this.why}
          @hold-start=${() => this.emit("jog-hold", a.key, -1)}
          @hold-end=${() => this.emit("jog-release", a.key, -1)}
        ></op-hold-button>
        <span class="value" data-testid="jog-value">${a.value}</span>
        <op-hold-button
          data-testid="jog-plus"
          ${jogs}
          label="+"
          aria-label=${t("jog.axis_plus", { axis: a.label })}
          ?disabled=${this.disabled}
          why=${this.why}
          @hold-start=${() => this.emit("jog-hold", a.key, 1)}
          @hold-end=${() => this.emit("jog-release", a.key, 1)}
        ></op-hold-button>
      </div>`,
    )}`;
  }
}

customElements.define("op-jog-pad", OpJogPad);
