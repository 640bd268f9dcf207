import { LitElement, css, html } from "lit";
import { client, errorText, ok, type Schemas } from "../api";
import { HOLDER_MAX, control } from "../control";
import { LANGUAGES, type Language, type StringKey, language, setLanguage, t } from "../i18n";
import { type Theme, currentTheme, setTheme } from "../theme";
import { makes, request } from "../rights";
import { session } from "../session";
import { shared } from "../styles";
import "../components/tls-trust";
import { type PluginInfo, plugins } from "../plugins";
import { type AngleUnit, type LengthUnit, setUnits, units } from "../units";

type Health = Schemas["Health"];
type LogEntry = Schemas["LogEntry"];

// Service states and log levels the runtime is known to send; any other is shown as it comes.
const SERVICE_STATUS: Record<string, StringKey> = {
  ok: "system.service.ok",
  starting: "system.service.starting",
  down: "system.service.down",
};
const LOG_LEVEL: Record<string, StringKey> = {
  debug: "system.level.debug",
  info: "system.level.info",
  warning: "system.level.warning",
  error: "system.level.error",
  critical: "system.level.critical",
};
const LENGTH_UNITS: LengthUnit[] = ["mm", "in"];
const ANGLE_UNITS: [AngleUnit, string][] = [
  ["deg", "°"],
  ["rad", "rad"],
];

// This pendant (its name, light or dark, its language and units), and the runtime's services
// and whether each is healthy, refreshed every two seconds.
export class OpSystemPanel extends LitElement {
  static properties = {
    health: { state: true },
    error: { state: true },
    theme: { state: true },
    nameNote: { state: true },
    logs: { state: true },
    logLevel: { state: true },
    tls: { state: true },
  };
  declare logs: LogEntry[] | null;
  declare logLevel: "warning" | "info";
  declare health: Health | null;
  declare error: string;
  declare theme: Theme;
  declare nameNote: string;
  declare tls: Schemas["TlsStatus"] | null;
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
      /* The tables fit a 360 px phone: tighter cells, a long name broken, not the page widened. */
      @media (max-width: 700px) {
        table {
          font-size: 15px;
        }
        th,
        td {
          padding: 8px 4px;
        }
        td {
          overflow-wrap: anywhere;
        }
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
    this.tls = null;
  }

  private chooseTheme(theme: Theme): void {
    setTheme(theme);
    this.theme = theme;
  }

  private chooseUnits(length: LengthUnit, angle: AngleUnit): void {
    setUnits(length, angle);
    this.requestUpdate(); // pressed at once, not only when the page-wide redraw comes
  }

  private rename(): void {
    const input = this.renderRoot.querySelector<HTMLInputElement>("[data-testid=pendant-name]");
    try {
      control.rename(input?.value ?? "");
      this.nameNote = t("system.name_note", { name: control.holder });
    } catch (err) {
      this.nameNote = errorText(err);
    }
  }

  private pendant() {
    return html`<section class="card">
      <h2>${t("system.pendant")}</h2>
      <div class="row">
        <label for="pendant-name">${t("system.name")}</label>
        <input id="pendant-name" data-testid="pendant-name" maxlength=${HOLDER_MAX}
          .value=${control.holder} autocomplete="off" />
        <button data-testid="save-pendant-name" @click=${() => this.rename()}>
          ${t("system.save_name")}
        </button>
      </div>
      ${this.nameNote ? html`<p class="muted" data-testid="pendant-name-note">${this.nameNote}</p>` : ""}
      <div class="row" role="group" aria-label=${t("system.display")}>
        <span>${t("system.display")}</span>
        ${(["dark", "light"] as Theme[]).map((theme) => html`<button data-testid="theme-${theme}"
          aria-pressed=${this.theme === theme ? "true" : "false"}
          @click=${() => this.chooseTheme(theme)}
          >${theme === "dark" ? t("system.theme.dark") : t("system.theme.light")}</button>`)}
      </div>
      <div class="row" role="group" aria-label=${t("system.language")}>
        <span>${t("system.language")}</span>
        ${Object.entries(LANGUAGES).map(([code, { name }]) => html`<button
          data-testid="language-${code}" lang=${code} translate="no"
          aria-pressed=${language() === code ? "true" : "false"}
          @click=${() => setLanguage(code as Language)}>${name}</button>`)}
      </div>
      <div class="row" role="group" aria-label=${t("system.units.length")}>
        <span>${t("system.units.length")}</span>
        ${LENGTH_UNITS.map((unit) => html`<button data-testid="units-length-${unit}"
          aria-pressed=${units.length === unit ? "true" : "false"}
          @click=${() => this.chooseUnits(unit, units.angle)}>${unit}</button>`)}
      </div>
      <div class="row" role="group" aria-label=${t("system.units.angle")}>
        <span>${t("system.units.angle")}</span>
        ${ANGLE_UNITS.map(([unit, label]) => html`<button data-testid="units-angle-${unit}"
          aria-pressed=${units.angle === unit ? "true" : "false"}
          @click=${() => this.chooseUnits(units.length, unit)}>${label}</button>`)}
      </div>
      <p class="muted">${t("system.settings_hint")}</p>
    </section>`;
  }

  connectedCallback(): void {
    super.connectedCallback();
    void this.refresh();
    void client.GET("/api/auth/status").then(({ data }) => (this.tls = data?.tls ?? null));
    this.timer = window.setInterval(() => void this.refresh(), 2000);
  }

  disconnectedCallback(): void {
    window.clearInterval(this.timer);
    super.disconnectedCallback();
  }

  private async refresh() {
    try {
      // The plugins' report failing hides neither health nor logs.
      // The runtime's logs are for programmers and administrators.
      const [health, logs] = await Promise.all([
        ok(client.GET("/api/health")),
        session.may("GET", "/api/logs")
          ? ok(client.GET("/api/logs", { params: { query: { level: this.logLevel, limit: 100 } } }))
          : Promise.resolve(null),
        plugins.load().catch(() => undefined),
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

  private account() {
    const me = session.me;
    if (me === null) return "";
    return html`<section class="card account">
      <p data-testid="signed-in-as">
        ${t("auth.signed_in_as", { user: me.user, role: t(`auth.role.${me.role}`) })}
      </p>
      <button data-testid="sign-out" @click=${() => void this.signOut()}
        ${makes(request("POST", "/api/auth/logout"))}>${t("auth.sign_out")}</button>
    </section>`;
  }

  private async signOut(): Promise<void> {
    try {
      await ok(client.POST("/api/auth/logout"));
    } catch (err) {
      this.error = errorText(err);
    }
    location.hash = "";
    void session.set(null);
  }

  private log() {
    if (!session.may("GET", "/api/logs")) return "";
    const levels: ["warning" | "info", StringKey][] = [
      ["warning", "system.log.warnings"],
      ["info", "system.log.everything"],
    ];
    return html`<section class="card">
      <h2>${t("system.log.heading")}</h2>
      <div class="row" role="group" aria-label=${t("system.log.which")}>
        ${levels.map(([level, label]) => html`<button data-testid="log-${level}"
          aria-pressed=${this.logLevel === level ? "true" : "false"}
          @click=${() => this.showLevel(level)}>${t(label)}</button>`)}
      </div>
      ${this.logs === null ? html`<p class="muted">${t("system.loading")}</p>`
        : this.logs.length === 0
        ? html`<p class="muted" data-testid="log-empty">${t("system.log.empty")}</p>`
        : html`<div class="log" data-testid="log">
            ${this.logs.map((e) => html`<div class="entry" data-testid="log-entry">
              <span class="muted">${e.time.replace("T", " ")}</span>
              <span class="chip ${e.level === "error" || e.level === "critical" ? "bad"
                : e.level === "warning" ? "warn" : ""}">${shownAs(LOG_LEVEL, e.level)}</span>
              <strong translate="no">${e.service}</strong>
              <div class="message" translate="no">${e.message}</div>
            </div>`)}
          </div>`}
    </section>`;
  }

  private plugins() {
    const report = plugins.report;
    if (report === null) return "";
    const adds = (p: PluginInfo): string =>
      (
        [
          ["system.plugins.kinds", p.kinds],
          ["system.plugins.drivers", p.drivers],
          ["system.plugins.blocks", p.blocks],
          ["system.plugins.services", p.services],
          ["system.plugins.panels", p.panels],
        ] as [StringKey, string[]][]
      )
        .filter(([, items]) => items.length > 0)
        .map(([key, items]) => `${t(key)}: ${items.length > 4 ? items.length : items.join(", ")}`)
        .join(" · ");
    return html`<section class="card" data-testid="plugins">
      <h2>${t("system.plugins")}</h2>
      ${report.failures.map((f) => html`<p class="error" role="alert" data-testid="plugin-failure">
        <strong>${t("system.plugins.failed")}:</strong>
        <span translate="no">${f.plugin} (${f.source}) ${f.error}</span>
        <span class="muted">${t("system.plugins.failed_in", { process: f.process })}</span>
      </p>`)}
      <table>
        <tbody>
          ${report.plugins.map((p) => html`<tr data-testid="plugin" data-name=${p.name}>
            <td translate="no"><strong>${p.name}</strong></td>
            <td translate="no">${p.builtin ? t("system.plugins.builtin") : `${p.package} ${p.version}`}</td>
            <td><span class="muted" translate="no">${adds(p)}</span></td>
          </tr>`)}
        </tbody>
      </table>
    </section>`;
  }

  render() {
    const services = Object.entries(this.health?.services ?? {});
    return html`
      ${this.account()}
      ${this.pendant()}
      ${this.tls
        ? html`<section class="card" data-testid="system-tls">
            <h2>${t("tls.title")}</h2>
            <op-tls-trust .tls=${this.tls}></op-tls-trust>
          </section>`
        : ""}
      <h2>${t("system.services")}</h2>
      ${this.error ? html`<p class="error" role="alert">${this.error}</p>` : ""}
      <div class="card">
        <table data-testid="services">
          <thead>
            <tr>
              <th>${t("system.service")}</th>
              <th>${t("system.status")}</th>
              <th>${t("system.version")}</th>
              <th>${t("system.uptime")}</th>
            </tr>
          </thead>
          <tbody>
            ${services.map(
              ([name, s]) => html`<tr data-testid="service" data-name=${name}>
                <td translate="no">${name}</td>
                <td>
                  <span class="chip ${s.status === "ok" ? "ok" : "bad"}"
                    >${shownAs(SERVICE_STATUS, s.status)}</span
                  >
                  ${s.message ? html`<span class="muted" translate="no">${s.message}</span>` : ""}
                </td>
                <td translate="no">${s.version ?? ""}</td>
                <td translate="no">
                  ${s.uptime_s != null
                    ? t("system.seconds", { seconds: Math.round(s.uptime_s) })
                    : ""}
                </td>
              </tr>`,
            )}
          </tbody>
        </table>
      </div>
      ${this.plugins()}
      ${this.log()}
      <p class="note muted">
        ${t("system.stop_note")}
      </p>
    `;
  }
}

function shownAs(known: Record<string, StringKey>, value: string): string {
  return value in known ? t(known[value]) : value;
}

customElements.define("op-system-panel", OpSystemPanel);
