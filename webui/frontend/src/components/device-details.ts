import { LitElement, css, html } from "lit";
import { api, errorText } from "../api";
import { deg } from "../format";
import { shared } from "../styles";
import type { DeviceDetails } from "../types";
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
      this.details = await api<DeviceDetails>("GET", `/api/devices/${encodeURIComponent(this.name)}`);
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private close() {
    this.dispatchEvent(new CustomEvent("close", { bubbles: true, composed: true }));
  }

  render() {
    const d = this.details;
    const info = d?.info?.info;
    return html`<op-modal heading="Device ${this.name}">
      ${this.error ? html`<p class="error">${this.error}</p>` : ""}
      ${d
        ? html`<dl>
            <dt>Name</dt><dd>${d.name}</dd>
            <dt>Kind</dt><dd>${d.kind}</dd>
            <dt>Model</dt><dd>${info ? `${info.manufacturer} ${info.model}` : d.model}</dd>
            <dt>Address</dt><dd>${d.url}</dd>
            <dt>UUID</dt><dd>${d.uuid}</dd>
            <dt>Status</dt><dd>${d.status}${d.last_error ? ` — ${d.last_error}` : ""}</dd>
            ${info?.description ? html`<dt>About</dt><dd>${info.description}</dd>` : ""}
          </dl>`
        : this.error
          ? ""
          : html`<p class="muted">Loading…</p>`}
      ${info
        ? html`<table data-testid="joint-limits">
            <thead>
              <tr><th>Joint</th><th>Min °</th><th>Max °</th><th>Max °/s</th></tr>
            </thead>
            <tbody>
              ${info.joints.map(
                (j, i) => html`<tr>
                  <td>J${i + 1} <span class="muted">${j.name}</span></td>
                  <td>${deg(j.lower)}</td>
                  <td>${deg(j.upper)}</td>
                  <td>${deg(j.max_velocity)}</td>
                </tr>`,
              )}
            </tbody>
          </table>`
        : ""}
      <div class="actions"><button @click=${this.close}>Close</button></div>
    </op-modal>`;
  }
}

customElements.define("op-device-details", OpDeviceDetails);
