import { LitElement, css, html } from "lit";
import { t } from "./i18n";
import { ApiError, client, ok } from "./api";
import { Listening } from "./listening";
import { feed } from "./live";
import { ADMIN_PANELS, panels } from "./panels/registry";
import { plugins } from "./plugins";
import { session } from "./session";
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
      /* The shell is the viewport: the document never scrolls, so nothing (a swipe, a tap
         that brings a control into view, an anchor) can move the safety bar off the screen.
         Only the navigation and the panel scroll, each inside itself. */
      :host {
        position: fixed;
        inset: 0;
        display: grid;
        grid-template-rows: auto minmax(0, 1fr);
        grid-template-columns: minmax(0, 1fr);
        overflow: clip;
        background: var(--bg);
      }
      :host([signed-out]) {
        display: block;
        overflow: auto;
      }
      .body {
        display: grid;
        grid-template-columns: 112px minmax(0, 1fr);
        grid-template-rows: minmax(0, 1fr);
        min-height: 0;
        overflow: clip;
      }
      nav {
        display: flex;
        flex-direction: column;
        gap: 8px;
        padding: 10px 8px;
        min-height: 0;
        overflow-x: hidden;
        overflow-y: auto;
        overscroll-behavior: contain;
        background: var(--panel);
        border-right: 1px solid var(--line);
      }
      nav button {
        flex: none;
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
        overscroll-behavior: contain;
        padding: 16px;
        min-width: 0;
        min-height: 0;
      }
      @media (max-width: 700px) {
        .body {
          grid-template-columns: minmax(0, 1fr);
          grid-template-rows: minmax(0, 1fr) auto;
        }
        /* A row at the bottom that scrolls sideways when the panels do not fit the width. */
        nav {
          order: 2;
          flex-direction: row;
          gap: 2px;
          padding: 4px 2px;
          min-width: 0;
          overflow-x: auto;
          overflow-y: hidden;
          border-right: none;
          border-top: 1px solid var(--line);
        }
        nav button {
          flex: 1 0 60px;
          min-width: 60px;
          min-height: 64px;
          padding: 4px 0;
          font-size: 10.5px;
          letter-spacing: -0.2px;
          overflow: hidden;
        }
        /* A long name (German) is cut, not the page. */
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
    new Listening(this, window, "hashchange", this.onHash);
    new Listening(this, plugins, "change", this.onPlugins);
    new Listening(this, session, "change", this.onSession);
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
    void this.resume();
  }

  /** A session this browser already has (its cookie) signs it in without a screen. */
  private async resume(): Promise<void> {
    try {
      await session.set(await ok(client.GET("/api/auth/me")));
    } catch (err) {
      // A cookie whose session ended lately (reloaded, or the tablet woke up): say why.
      if (err instanceof ApiError && err.code === "session_ended") {
        session.ended = { message: err.message, words: err.words };
      }
      await session.set(null);
    }
    this.checked = true;
    this.requestUpdate();
  }

  disconnectedCallback(): void {
    window.clearTimeout(this.retry);
    super.disconnectedCallback();
  }

  /** Until the runtime answers, the built-in panels show; asked again every 2 s. */
  private loadPlugins(): void {
    plugins.load().catch(() => {
      this.retry = window.setTimeout(() => this.loadPlugins(), 2000);
    });
  }

  protected willUpdate(): void {
    this.toggleAttribute("signed-out", session.me === null);
  }

  private revealed = "";

  protected updated(): void {
    const nav = this.renderRoot.querySelector("nav");
    const current = nav?.querySelector<HTMLElement>('button[aria-current="page"]');
    const key = `${this.panel}:${nav?.childElementCount ?? 0}`;
    if (!nav || !current || key === this.revealed) return;
    this.revealed = key;
    // The current panel's entry shown (a link to the last one, or more panels than fit), by
    // scrolling the navigation alone: scrollIntoView would scroll every ancestor it can.
    const box = nav.getBoundingClientRect();
    const entry = current.getBoundingClientRect();
    if (entry.top < box.top) nav.scrollTop -= box.top - entry.top;
    else if (entry.bottom > box.bottom) nav.scrollTop += entry.bottom - box.bottom;
    if (entry.left < box.left) nav.scrollLeft -= box.left - entry.left;
    else if (entry.right > box.right) nav.scrollLeft += entry.right - box.right;
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
