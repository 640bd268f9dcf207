import { LitElement, css, html } from "lit";
import { ApiError, client, errorText, ok } from "./api";
import { t } from "./i18n";
import { worded } from "./i18n/words";
import { type AuthStatus, type Me, session } from "./session";
import { shared } from "./styles";
import "./components/tls-trust";

type Mode = "password" | "pin";

// The first screen: on the very first start the set-up of the administrator, then signing
// in with a password (or, for an operator on a shared tablet, a PIN).
export class OpSignIn extends LitElement {
  static properties = {
    status: { state: true },
    mode: { state: true },
    error: { state: true },
    busy: { state: true },
  };
  declare status: AuthStatus | null;
  declare mode: Mode;
  declare error: string;
  declare busy: boolean;

  static styles = [
    shared,
    css`
      :host {
        display: grid;
        place-items: center;
        min-height: 100vh;
        min-height: 100dvh;
        padding: 16px;
        background: var(--bg);
      }
      form {
        display: grid;
        gap: 14px;
        width: min(440px, 100%);
        padding: 24px;
        border-radius: 14px;
        background: var(--panel);
        border: 1px solid var(--line);
      }
      h1 {
        margin: 0 0 4px;
        font-size: 26px;
      }
      label {
        display: grid;
        gap: 6px;
        font-size: 16px;
      }
      .modes {
        display: grid;
        grid-template-columns: 1fr 1fr;
        gap: 8px;
      }
      .modes button[aria-pressed="true"] {
        border-color: var(--accent);
        color: var(--accent);
      }
      .error {
        color: var(--error-fg);
      }
      .hint {
        color: var(--muted);
        font-size: 15px;
      }
      .ended {
        margin: 0;
        padding: 12px 14px;
        border-radius: 10px;
        border: 2px solid var(--warn);
        font-size: 17px;
      }
    `,
  ];

  constructor() {
    super();
    this.status = null;
    this.mode = "password";
    this.error = "";
    this.busy = false;
  }

  connectedCallback(): void {
    super.connectedCallback();
    void this.load();
  }

  private async load(): Promise<void> {
    try {
      this.status = await ok(client.GET("/api/auth/status"));
    } catch (err) {
      this.error = errorText(err);
      window.setTimeout(() => void this.load(), 2000);
    }
  }

  private field(name: string): string {
    const input = this.renderRoot.querySelector<HTMLInputElement>(`[name="${name}"]`);
    return input?.value ?? "";
  }

  private async submit(e: Event): Promise<void> {
    e.preventDefault();
    if (this.busy || this.status === null) return;
    this.busy = true;
    this.error = "";
    try {
      session.set(await this.send());
    } catch (err) {
      this.error = err instanceof ApiError || err instanceof Error ? err.message : String(err);
    } finally {
      this.busy = false;
    }
  }

  private async send(): Promise<Me> {
    const user = this.field("user").trim();
    if (!this.status?.set_up) {
      if (this.field("password") !== this.field("repeat")) throw new Error(t("auth.mismatch"));
      const code = this.field("code").trim();
      return ok(client.POST("/api/auth/setup",
        { body: { user, password: this.field("password"), code: code || null } }));
    }
    if (this.mode === "pin") {
      return ok(client.POST("/api/auth/pin", { body: { user, pin: this.field("pin") } }));
    }
    return ok(client.POST("/api/auth/login", { body: { user, password: this.field("password") } }));
  }

  render() {
    if (this.status === null) {
      return html`<p class="muted">${this.error || t("auth.connecting")}</p>`;
    }
    const setup = !this.status.set_up;
    return html`<form @submit=${this.submit} data-testid="sign-in">
      <h1>${setup ? t("auth.setup_title") : t("auth.title")}</h1>
      ${setup ? html`<p class="hint">${t("auth.setup_hint")}</p>` : this.endedNote()}
      ${setup ? "" : this.modes()}
      <label
        >${t("auth.user")}
        <input name="user" data-testid="sign-in-user" autocomplete="username"
          autocapitalize="none" spellcheck="false" required
      /></label>
      ${this.mode === "pin" && !setup
        ? html`<label
            >${t("auth.pin")}
            <input name="pin" data-testid="sign-in-pin" type="password" inputmode="numeric"
              autocomplete="off" required
          /></label>`
        : html`<label
            >${t("auth.password")}
            <input name="password" data-testid="sign-in-password" type="password"
              autocomplete=${setup ? "new-password" : "current-password"} required
          /></label>`}
      ${setup
        ? html`<label
              >${t("auth.repeat")}
              <input name="repeat" data-testid="sign-in-repeat" type="password"
                autocomplete="new-password" required
            /></label>
            ${this.status.setup_needs_code
              ? html`<label
                  >${t("auth.code")}
                  <input name="code" data-testid="sign-in-code" autocomplete="off" required
                /></label>`
              : ""}`
        : ""}
      <div class="error" role="alert" data-testid="sign-in-error">${this.error}</div>
      <button class="primary" type="submit" data-testid="sign-in-submit" ?disabled=${this.busy}>
        ${setup ? t("auth.create_admin") : t("auth.sign_in")}
      </button>
      ${setup && this.status.tls
        ? html`<h2>${t("tls.title")}</h2><op-tls-trust .tls=${this.status.tls}></op-tls-trust>`
        : ""}
    </form>`;
  }

  /** Why this tablet was signed out, when it was (the session expired, ended elsewhere…). */
  private endedNote() {
    const ended = session.ended;
    if (ended === null) return "";
    const why = worded(ended.message, ended.words) || t("auth.ended_unknown");
    return html`<p class="ended" role="status" data-testid="sign-in-ended">${why}</p>`;
  }

  private modes() {
    const choose = (mode: Mode) => () => {
      this.mode = mode;
      this.error = "";
    };
    return html`<div class="modes" role="group">
      <button type="button" aria-pressed=${this.mode === "password"} @click=${choose("password")}>
        ${t("auth.password")}
      </button>
      <button type="button" data-testid="sign-in-pin-mode" aria-pressed=${this.mode === "pin"}
        @click=${choose("pin")}>
        ${t("auth.pin")}
      </button>
    </div>`;
  }
}

customElements.define("op-sign-in", OpSignIn);
