import { LitElement, css, html } from "lit";
import { deg, mm } from "../format";
import { shared } from "../styles";
import type { RobotState } from "../types";

// Live joint values (degrees) and TCP position (mm) of one robot.
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
    if (!s) return html`<p class="muted">Waiting for state…</p>`;
    const [x, y, z] = s.tcp_pose.position;
    return html`
      <div class="joints" data-testid="joint-values">
        ${s.joint_position.map(
          (q, i) =>
            html`<div class="value" data-testid="joint-value">
              <small>J${i + 1}</small>${deg(q)}°
            </div>`,
        )}
      </div>
      <div class="tcp muted" data-testid="tcp-position">
        TCP X ${mm(x)} · Y ${mm(y)} · Z ${mm(z)} mm
      </div>
    `;
  }
}

customElements.define("op-robot-live", OpRobotLive);
