import { LitElement, css, html } from "lit";
import { api, errorText } from "../api";
import { HOLDER_MAX, control } from "../control";
import { type Theme, currentTheme, setTheme } from "../theme";
import { shared } from "../styles";
import type { Health } from "../types";

interface LogEntry {
  time: string;
  level: string;
  service: string;
  message: string;
}

// This pendant (its name, light or dark), and the runtime's services and whether each is
// healthy, refreshed every two seconds.
export class OpSystemPanel extends LitElement {
  static properties = {
    health: { state: true },
    error: { state: true },
    theme: { state: true },
    nameNote: { state: true },
    logs: { state: true },
    logLevel: { state: true },
  };
  declare logs: LogEntry[] | null;
  declare logLevel: "warning" | "info";
  declare health: Health | null;
  declare error: string;
  declare theme: Theme;
  declare nameNote: string;
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
      .row {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
        align-items: center;
        margin-bottom: 12px;
      }
      .row input {
        flex: 1 1 220px;
        width: auto;
      }
      button[aria-pressed="true"] {
        border-color: var(--accent);
        color: var(--accent);
      }
      section.card {
        margin-bottom: 14px;
      }
      .log {
        max-height: 420px;
        overflow-y: auto;
      }
      .entry {
        display: flex;
        flex-wrap: wrap;
        gap: 6px 10px;
        align-items: center;
        padding: 8px 0;
        border-bottom: 1px solid var(--line);
        font-size: 16px;
      }
      .entry .message {
        flex: 1 1 100%;
        overflow-wrap: anywhere;
      }
    `,
  ];

  constructor() {
    super();
    this.health = null;
    this.error = "";
    this.theme = currentTheme();
    this.nameNote = "";
    this.logs = null;
    this.logLevel = "warning";
  }

  private chooseTheme(theme: Theme): void {
    setTheme(theme);
    this.theme = theme;
  }

  private rename(): void {
    const input = this.renderRoot.querySelector<HTMLInputElement>("[data-testid=pendant-name]");
    try {
      control.rename(input?.value ?? "");
      this.nameNote = `Others now see "${control.holder}" while this pendant has control.`;
    } catch (err) {
      this.nameNote = errorText(err);
    }
  }

  private pendant() {
    return html`<section class="card">
      <h2>This pendant</h2>
      <div class="row">
        <label for="pendant-name">Name</label>
        <input id="pendant-name" data-testid="pendant-name" maxlength=${HOLDER_MAX}
          .value=${control.holder} autocomplete="off" />
        <button data-testid="save-pendant-name" @click=${() => this.rename()}>Save name</button>
      </div>
      ${this.nameNote ? html`<p class="muted" data-testid="pendant-name-note">${this.nameNote}</p>` : ""}
      <div class="row" role="group" aria-label="Display">
        <span>Display</span>
        ${(["dark", "light"] as Theme[]).map((t) => html`<button data-testid="theme-${t}"
          aria-pressed=${this.theme === t ? "true" : "false"}
          @click=${() => this.chooseTheme(t)}>${t === "dark" ? "Dark" : "Light (bright rooms)"}</button>`)}
      </div>
    </section>`;
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
      const [health, logs] = await Promise.all([
        api<Health>("GET", "/api/health"),
        api<LogEntry[]>("GET", `/api/logs?level=${this.logLevel}&limit=100`),
      ]);
      this.health = health;
      this.logs = logs;
      this.error = "";
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private showLevel(level: "warning" | "info"): void {
    this.logLevel = level;
    this.logs = null;
    void this.refresh();
  }

  private log() {
    const levels: ["warning" | "info", string][] = [
      ["warning", "Warnings and errors"],
      ["info", "Everything"],
    ];
    return html`<section class="card">
      <h2>Recent log</h2>
      <div class="row" role="group" aria-label="Which entries">
        ${levels.map(([level, label]) => html`<button data-testid="log-${level}"
          aria-pressed=${this.logLevel === level ? "true" : "false"}
          @click=${() => this.showLevel(level)}>${label}</button>`)}
      </div>
      ${this.logs === null ? html`<p class="muted">Loading…</p>`
        : this.logs.length === 0 ? html`<p class="muted" data-testid="log-empty">Nothing to show.</p>`
        : html`<div class="log" data-testid="log">
            ${this.logs.map((e) => html`<div class="entry" data-testid="log-entry">
              <span class="muted">${e.time.replace("T", " ")}</span>
              <span class="chip ${e.level === "error" || e.level === "critical" ? "bad"
                : e.level === "warning" ? "warn" : ""}">${e.level}</span>
              <strong>${e.service}</strong>
              <div class="message">${e.message}</div>
            </div>`)}
          </div>`}
    </section>`;
  }

  render() {
    const services = Object.entries(this.health?.services ?? {});
    return html`
      ${this.pendant()}
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
      ${this.log()}
      <p class="note muted">
        The on-screen STOP is a software stop, not an emergency stop. Keep the robot's own
        E-stop within reach.
      </p>
    `;
  }
}

customElements.define("op-system-panel", OpSystemPanel);
