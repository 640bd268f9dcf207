import { LitElement, css, html } from "lit";
import { client, errorText, ok } from "../api";
import { linkLabel } from "../format";
import { t } from "../i18n";
import { shared } from "../styles";
import type { DeviceDetails, RobotInfo } from "../types";
import { angle, angleUnit } from "../units";
import "./modal";

// What the runtime knows about one added device: identity, address, limits.
export class OpDeviceDetails extends LitElement {
  static properties = {
    name: { type: String },
    details: { state: true },
    error: { state: true },
  };
  declare name: string;
  declare details: DeviceDetails | null;
  declare error: string;

  static styles = [
    shared,
    css`
      dl {
        display: grid;
        grid-template-columns: max-content 1fr;
        gap: 6px 14px;
        margin: 0 0 12px;
      }
      dt {
        color: var(--muted);
      }
      dd {
        margin: 0;
        overflow-wrap: anywhere;
      }
      table {
        width: 100%;
        border-collapse: collapse;
        font-size: 16px;
        font-variant-numeric: tabular-nums;
      }
      th,
      td {
        text-align: right;
        padding: 6px 4px;
        border-bottom: 1px solid var(--line);
      }
      th:first-child,
      td:first-child {
        text-align: left;
      }
      .actions {
        display: flex;
        justify-content: flex-end;
        margin-top: 16px;
      }
    `,
  ];

  constructor() {
    super();
    this.name = "";
    this.details = null;
    this.error = "";
  }

  async connectedCallback(): Promise<void> {
    super.connectedCallback();
    try {
      this.details = await ok(
        client.GET("/api/devices/{local_name}", { params: { path: { local_name: this.name } } }),
      );
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private close() {
    this.dispatchEvent(new CustomEvent("close", { bubbles: true, composed: true }));
  }

  render() {
    const d = this.details;
    // Any kind's driver info; a robot's names its joints' limits too.
    const info = d?.info?.info as Partial<RobotInfo> | undefined;
    return html`<op-modal heading=${t("devices.details_heading", { name: this.name })}>
      ${this.error ? html`<p class="error">${this.error}</p>` : ""}
      ${d
        ? html`<dl>
            <dt>${t("devices.info.name")}</dt><dd>${d.name}</dd>
            <dt>${t("devices.info.kind")}</dt><dd>${d.kind}</dd>
            <dt>${t("devices.info.model")}</dt>
            <dd>${info ? `${info.manufacturer} ${info.model}` : d.model}</dd>
            <dt>${t("devices.info.address")}</dt><dd>${d.url}</dd>
            <dt>${t("devices.info.uuid")}</dt><dd>${d.uuid}</dd>
            <dt>${t("devices.info.status")}</dt>
            <dd>${linkLabel(d.status)}${d.last_error ? ` — ${d.last_error}` : ""}</dd>
            ${info?.description
              ? html`<dt>${t("devices.info.about")}</dt><dd>${info.description}</dd>`
              : ""}
          </dl>`
        : this.error
          ? ""
          : html`<p class="muted">${t("devices.loading")}</p>`}
      ${info?.joints
        ? html`<table data-testid="joint-limits">
            <thead>
              <tr>
                <th>${t("devices.limits.joint")}</th>
                <th>${t("devices.limits.min", { unit: angleUnit() })}</th>
                <th>${t("devices.limits.max", { unit: angleUnit() })}</th>
                <th>${t("devices.limits.max_speed", { unit: angleUnit() })}</th>
              </tr>
            </thead>
            <tbody>
              ${info.joints.map(
                (j, i) => html`<tr>
                  <td>
                    ${t("devices.limits.joint_number", { number: i + 1 })}
                    <span class="muted">${j.name}</span>
                  </td>
                  <td>${angle(j.lower)}</td>
                  <td>${angle(j.upper)}</td>
                  <td>${angle(j.max_velocity)}</td>
                </tr>`,
              )}
            </tbody>
          </table>`
        : ""}
      <div class="actions"><button @click=${this.close}>${t("devices.close")}</button></div>
    </op-modal>`;
  }
}

customElements.define("op-device-details", OpDeviceDetails);
