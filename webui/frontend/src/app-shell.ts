import { LitElement, css, html } from "lit";
import { t } from "./i18n";
import { api } from "./api";
import { feed } from "./live";
import { ADMIN_PANELS, panels } from "./panels/registry";
import { plugins } from "./plugins";
import { type Me, session } from "./session";
import "./sign-in";
import { shared } from "./styles";
import "./status-bar";

function panelFromHash(): string {
  const id = location.hash.replace(/^#\/?/, "");
  // A plugin's panel is known once the runtime has said which there are.
  return id || panels()[0].id;
}

export class OpApp extends LitElement {
  static properties = { panel: { state: true } };
  declare panel: string;

  static styles = [
    shared,
    css`
      :host {
        display: grid;
        grid-template-rows: auto 1fr;
        height: 100vh;
        height: 100dvh;
        background: var(--bg);
      }
      .body {
        display: grid;
        grid-template-columns: 112px 1fr;
        min-height: 0;
      }
      nav {
        display: flex;
        flex-direction: column;
        gap: 8px;
        padding: 10px 8px;
        background: var(--panel);
        border-right: 1px solid var(--line);
      }
      nav button {
        display: flex;
        flex-direction: column;
        align-items: center;
        justify-content: center;
        gap: 4px;
        min-height: 84px;
        padding: 6px;
        font-size: 15px;
        background: transparent;
        border-color: transparent;
      }
      nav button[aria-current="page"] {
        background: var(--raised);
        border-color: var(--accent);
        color: var(--accent);
      }
      main {
        overflow: auto;
        padding: 16px;
        min-width: 0;
      }
      @media (max-width: 700px) {
        .body {
          grid-template-columns: 1fr;
          grid-template-rows: 1fr auto;
        }
        nav {
          order: 2;
          flex-direction: row;
          justify-content: space-around;
          border-right: none;
          border-top: 1px solid var(--line);
          padding: 6px;
        }
        nav {
          gap: 2px;
          padding: 4px 2px;
        }
        nav button {
          flex: 1;
          min-width: 0;
          min-height: 64px;
          padding: 4px 0;
          font-size: 10.5px;
          letter-spacing: -0.2px;
          overflow: hidden;
        }
        /* Seven panels share a phone's width: a long name (German) is cut, not the page. */
        nav button span {
          max-width: 100%;
          overflow: hidden;
          text-overflow: ellipsis;
          white-space: nowrap;
        }
        main {
          padding: 10px;
        }
      }
    `,
  ];

  constructor() {
    super();
    this.panel = panelFromHash();
  }

  private onHash = () => {
    this.panel = panelFromHash();
  };

  private onPlugins = () => this.requestUpdate();
  private retry = 0;
  private started = false;
  private checked = false;

  private onSession = () => {
    if (session.me !== null && !this.started) {
      // What needs a signed-in user starts once there is one.
      this.started = true;
      this.loadPlugins();
      feed.start();
    }
    this.requestUpdate();
  };

  connectedCallback(): void {
    super.connectedCallback();
    window.addEventListener("hashchange", this.onHash);
    plugins.addEventListener("change", this.onPlugins);
    session.addEventListener("change", this.onSession);
    void this.resume();
  }

  /** A session this browser already has (its cookie) signs it in without a screen. */
  private async resume(): Promise<void> {
    try {
      session.set(await api<Me>("GET", "/api/auth/me"));
    } catch {
      session.set(null);
    }
    this.checked = true;
    this.requestUpdate();
  }

  disconnectedCallback(): void {
    window.removeEventListener("hashchange", this.onHash);
    plugins.removeEventListener("change", this.onPlugins);
    session.removeEventListener("change", this.onSession);
    window.clearTimeout(this.retry);
    super.disconnectedCallback();
  }

  /** Until the runtime answers, the built-in panels show; asked again every 2 s. */
  private loadPlugins(): void {
    plugins.load().catch(() => {
      this.retry = window.setTimeout(() => this.loadPlugins(), 2000);
    });
  }

  render() {
    if (session.me === null) {
      return this.checked ? html`<op-sign-in></op-sign-in>` : html``;
    }
    const all = panels();
    const active = all.find((p) => p.id === this.panel) ?? all[0];
    const shown = all.filter((p) => !ADMIN_PANELS.has(p.id) || session.can("admin"));
    return html`
      <op-status-bar></op-status-bar>
      <div class="body">
        <nav aria-label=${t("app.panels")}>
          ${shown.map(
            (p) => html`<button
              data-testid="nav-${p.id}"
              aria-current=${p.id === active.id ? "page" : "false"}
              @click=${() => (location.hash = `#/${p.id}`)}
            >
              ${p.icon}<span>${p.title()}</span>
            </button>`,
          )}
        </nav>
        <main>${active.render()}</main>
      </div>
    `;
  }
}

customElements.define("op-app", OpApp);
