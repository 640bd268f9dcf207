import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { quaternionToRpy } from "../math";
import { shared } from "../styles";
import type { Pose } from "../types";
import { angle, angleUnit, length, lengthUnit, radians } from "../units";

// Where the TCP is, in the robot's base frame: X, Y, Z and roll, pitch, yaw, in the units
// chosen; dashes while its state is not known.
export class OpTcpReadout extends LitElement {
  static properties = { pose: { attribute: false } };
  declare pose: Pose | null;

  static styles = [
    shared,
    css`
      :host {
        display: block;
      }
      .readout {
        display: grid;
        grid-template-columns: repeat(3, 1fr);
        gap: 6px;
        margin-top: 10px;
        font-variant-numeric: tabular-nums;
      }
      .readout div {
        background: var(--panel);
        border-radius: 8px;
        padding: 6px 10px;
      }
      .readout small {
        display: block;
        color: var(--muted);
        font-size: 13px;
      }
    `,
  ];

  constructor() {
    super();
    this.pose = null;
  }

  render() {
    const pose = this.pose;
    const tcp = pose ? pose.position.map((v) => length(v)) : ["–", "–", "–"];
    const rpy = pose
      ? quaternionToRpy(pose.orientation).map((a) => angle(radians(a)))
      : ["–", "–", "–"];
    return html`<div class="readout" data-testid="tcp-readout">
      <div><small>X ${lengthUnit()}</small>${tcp[0]}</div>
      <div><small>Y ${lengthUnit()}</small>${tcp[1]}</div>
      <div><small>Z ${lengthUnit()}</small>${tcp[2]}</div>
      <div><small>${t("jog.roll", { unit: angleUnit() })}</small>${rpy[0]}</div>
      <div><small>${t("jog.pitch", { unit: angleUnit() })}</small>${rpy[1]}</div>
      <div><small>${t("jog.yaw", { unit: angleUnit() })}</small>${rpy[2]}</div>
    </div>`;
  }
}

customElements.define("op-tcp-readout", OpTcpReadout);
