import { LitElement, css, html } from "lit";
import { api, errorText } from "../api";
import { shared } from "../styles";
import type { Health } from "../types";

// The runtime's services and whether each is healthy, refreshed every two seconds.
export class OpSystemPanel extends LitElement {
  static properties = { health: { state: true }, error: { state: true } };
  declare health: Health | null;
  declare error: string;
  private timer = 0;

  static styles = [
    shared,
    css`
      table {
        width: 100%;
        border-collapse: collapse;
        font-variant-numeric: tabular-nums;
      }
      th,
      td {
        text-align: left;
        padding: 10px 8px;
        border-bottom: 1px solid var(--line);
      }
      .note {
        margin-top: 20px;
      }
    `,
  ];

  constructor() {
    super();
    this.health = null;
    this.error = "";
  }

  connectedCallback(): void {
    super.connectedCallback();
    void this.refresh();
    this.timer = window.setInterval(() => void this.refresh(), 2000);
  }

  disconnectedCallback(): void {
    window.clearInterval(this.timer);
    super.disconnectedCallback();
  }

  private async refresh() {
    try {
      this.health = await api<Health>("GET", "/api/health");
      this.error = "";
    } catch (err) {
      this.error = errorText(err);
    }
  }

  render() {
    const services = Object.entries(this.health?.services ?? {});
    return html`
      <h2>Runtime services</h2>
      ${this.error ? html`<p class="error" role="alert">${this.error}</p>` : ""}
      <div class="card">
        <table data-testid="services">
          <thead>
            <tr><th>Service</th><th>Status</th><th>Version</th><th>Up for</th></tr>
          </thead>
          <tbody>
            ${services.map(
              ([name, s]) => html`<tr data-testid="service" data-name=${name}>
                <td>${name}</td>
                <td>
                  <span class="chip ${s.status === "ok" ? "ok" : "bad"}">${s.status}</span>
                  ${s.message ? html`<span class="muted">${s.message}</span>` : ""}
                </td>
                <td>${s.version ?? ""}</td>
                <td>${s.uptime_s !== undefined ? `${Math.round(s.uptime_s)} s` : ""}</td>
              </tr>`,
            )}
          </tbody>
        </table>
      </div>
      <p class="note muted">
        The on-screen STOP is a software stop, not an emergency stop. Keep the robot's own
        E-stop within reach.
      </p>
    `;
  }
}

customElements.define("op-system-panel", OpSystemPanel);
