import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { shared } from "../styles";
import type { RobotState } from "../types";
import { angleWithUnit, length, lengthUnit } from "../units";

// Live joint values and TCP position of one robot, in the chosen units.
export class OpRobotLive extends LitElement {
  static properties = { state: { attribute: false } };
  declare state: RobotState | undefined;

  static styles = [
    shared,
    css`
      .joints {
        display: grid;
        grid-template-columns: repeat(auto-fill, minmax(84px, 1fr));
        gap: 6px;
      }
      .value {
        background: var(--bg);
        border-radius: 8px;
        padding: 6px 8px;
        text-align: right;
        font-variant-numeric: tabular-nums;
      }
      .value small {
        display: block;
        text-align: left;
        color: var(--muted);
        font-size: 13px;
      }
      .tcp {
        margin-top: 8px;
        font-variant-numeric: tabular-nums;
      }
    `,
  ];

  render() {
    const s = this.state;
    if (!s) return html`<p class="muted">${t("jog.waiting_for_state")}</p>`;
    const [x, y, z] = s.tcp_pose.position;
    return html`
      <div class="joints" data-testid="joint-values">
        ${s.joint_position.map(
          (q, i) =>
            html`<div class="value" data-testid="joint-value">
              <small>${t("jog.joint_short", { number: i + 1 })}</small>${angleWithUnit(q)}
            </div>`,
        )}
      </div>
      <div class="tcp muted" data-testid="tcp-position" translate="no">
        ${t("jog.tcp_position", { x: length(x), y: length(y), z: length(z), unit: lengthUnit() })}
      </div>
    `;
  }
}

customElements.define("op-robot-live", OpRobotLive);
