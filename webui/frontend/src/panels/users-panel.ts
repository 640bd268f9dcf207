import { LitElement, css, html } from "lit";
import { client, errorText, ok, type Schemas } from "../api";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { type RoleName, session } from "../session";
import { shared } from "../styles";

type UserRow = Schemas["UserRow"];
type TokenRow = Schemas["TokenRow"];
type AuditRow = Schemas["AuditRow"];

const ROLES: RoleName[] = ["viewer", "operator", "programmer", "admin"];

// An administrator's page: the users and their roles, API tokens for scripts, and the audit
// log. Every change asks for the administrator's own password again.
export class OpUsersPanel extends LitElement {
  static properties = {
    users: { state: true },
    tokens: { state: true },
    audit: { state: true },
    role: { state: true },
    tokenRole: { state: true },
    error: { state: true },
    newToken: { state: true },
    editing: { state: true },
    editRole: { state: true },
  };
  declare users: UserRow[];
  declare tokens: TokenRow[];
  declare audit: AuditRow[];
  declare role: RoleName;
  declare tokenRole: RoleName;
  declare error: string;
  declare newToken: string;
  declare editing: string;
  declare editRole: RoleName;

  static styles = [
    shared,
    css`
      form {
        display: grid;
        gap: 10px;
        max-width: 560px;
      }
      .roles {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
      }
      .roles button[aria-pressed="true"] {
        border-color: var(--accent);
        color: var(--accent);
      }
      table {
        width: 100%;
        border-collapse: collapse;
      }
      td,
      th {
        text-align: left;
        padding: 8px 6px;
        border-bottom: 1px solid var(--line);
        overflow-wrap: anywhere;
      }
      label.check {
        display: flex;
        align-items: center;
        gap: 10px;
        min-height: var(--touch);
      }
      label.check input {
        width: 28px;
        height: 28px;
      }
      .audit {
        max-height: 360px;
        overflow: auto;
        font-size: 15px;
      }
      .token {
        font-family: monospace;
        overflow-wrap: anywhere;
      }
    `,
  ];

  constructor() {
    super();
    this.users = [];
    this.tokens = [];
    this.audit = [];
    this.role = "operator";
    this.tokenRole = "viewer";
    this.error = "";
    this.newToken = "";
    this.editing = "";
    this.editRole = "operator";
  }

  connectedCallback(): void {
    super.connectedCallback();
    if (session.may("GET", "/api/auth/users")) void this.load();
  }

  private async load(): Promise<void> {
    try {
      [this.users, this.tokens, this.audit] = await Promise.all([
        ok(client.GET("/api/auth/users")),
        ok(client.GET("/api/auth/tokens")),
        ok(client.GET("/api/auth/audit", { params: { query: { limit: 50 } } })),
      ]);
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private value(name: string): string {
    return this.renderRoot.querySelector<HTMLInputElement>(`[name="${name}"]`)?.value ?? "";
  }

  private async act(work: () => Promise<unknown>): Promise<void> {
    this.error = "";
    try {
      await work();
      await this.load();
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private addUser(e: Event): void {
    e.preventDefault();
    void this.act(() =>
      ok(client.POST("/api/auth/users", {
        body: {
          name: this.value("new-user").trim(),
          role: this.role,
          password: this.value("new-password"),
          confirm_password: this.value("confirm-user"),
        },
      })),
    );
  }

  private removeUser(name: string): void {
    const confirm = this.value("confirm-user");
    void this.act(() => ok(client.DELETE("/api/auth/users/{name}",
      { params: { path: { name } }, body: { confirm_password: confirm } })));
  }

  private edit(user: UserRow): void {
    this.editing = user.name;
    this.editRole = user.role;
  }

  private changeUser(e: Event, user: UserRow): void {
    e.preventDefault();
    const change: Schemas["UserChange"] = { confirm_password: this.value("confirm-edit") };
    if (this.editRole !== user.role) change.role = this.editRole;
    const password = this.value("edit-password");
    if (password) change.password = password;
    const pin = this.value("edit-pin").trim();
    const noPin = this.renderRoot.querySelector<HTMLInputElement>('[name="edit-no-pin"]')?.checked;
    if (noPin) change.pin = "";
    else if (pin) change.pin = pin;
    void this.act(async () => {
      await ok(client.PUT("/api/auth/users/{name}",
        { params: { path: { name: user.name } }, body: change }));
      this.editing = "";
    });
  }

  private editor(user: UserRow) {
    return html`<form data-testid="change-user" @submit=${(e: Event) => this.changeUser(e, user)}>
      <h3 translate="no">${user.name}</h3>
      ${this.roleButtons(this.editRole, (r) => (this.editRole = r), "edit-role")}
      <input name="edit-password" data-testid="edit-password" type="password"
        autocomplete="new-password" placeholder=${t("users.new_password")} />
      <input name="edit-pin" data-testid="edit-pin" inputmode="numeric" autocomplete="off"
        pattern="[0-9]{4,8}" placeholder=${t("users.new_pin")} />
      ${user.has_pin
        ? html`<label class="check"><input type="checkbox" name="edit-no-pin" data-testid="edit-no-pin" />
            ${t("users.remove_pin")}</label>`
        : ""}
      <input name="confirm-edit" data-testid="confirm-edit" type="password"
        autocomplete="current-password" placeholder=${t("users.your_password")} required />
      <div class="roles">
        <button class="primary" type="submit" data-testid="save-user"
          ${makes(request("PUT", `/api/auth/users/${encodeURIComponent(user.name)}`))}>${t("users.save")}</button>
        <button type="button" data-testid="cancel-edit" @click=${() => (this.editing = "")}>
          ${t("users.cancel")}</button>
      </div>
    </form>`;
  }

  private addToken(e: Event): void {
    e.preventDefault();
    void this.act(async () => {
      const made = await ok(client.POST("/api/auth/tokens", {
        body: {
          name: this.value("token-name").trim(),
          role: this.tokenRole,
          confirm_password: this.value("confirm-token"),
        },
      }));
      this.newToken = made.token;
    });
  }

  private roleButtons(current: RoleName, choose: (role: RoleName) => void, prefix: string) {
    return html`<div class="roles" role="group">
      ${ROLES.map(
        (role) => html`<button type="button" data-testid="${prefix}-${role}"
          aria-pressed=${role === current} @click=${() => choose(role)}>${t(`auth.role.${role}`)}</button>`,
      )}
    </div>`;
  }

  render() {
    if (!session.may("GET", "/api/auth/users")) {
      return html`<p class="error" role="alert" data-testid="admin-only">${t("users.admin_only")}</p>`;
    }
    return html`
      ${this.error ? html`<p class="error" role="alert" data-testid="users-error">${this.error}</p>` : ""}
      <h2>${t("users.title")}</h2>
      <section class="card">
        <table data-testid="users">
          ${this.users.map(
            (u) => html`<tr data-testid="user" data-name=${u.name}>
              <td translate="no">${u.name}</td>
              <td>${t(`auth.role.${u.role}`)}${u.has_pin ? html` · ${t("auth.pin")}` : ""}</td>
              <td>
                <button data-testid="change-user-${u.name}" @click=${() => this.edit(u)}
                  ${makes(request("PUT", `/api/auth/users/${encodeURIComponent(u.name)}`))}>
                  ${t("users.change")}</button>
                ${u.name === session.me?.user
                  ? ""
                  : html`<button class="danger" data-testid="remove-user-${u.name}"
                      ${makes(request("DELETE", `/api/auth/users/${encodeURIComponent(u.name)}`))}
                      @click=${() => this.removeUser(u.name)}>${t("users.remove")}</button>`}
              </td>
            </tr>`,
          )}
        </table>
        ${this.users.filter((u) => u.name === this.editing).map((u) => this.editor(u))}
        <h3>${t("users.add")}</h3>
        <form @submit=${this.addUser}>
          <input name="new-user" data-testid="new-user" placeholder=${t("auth.user")}
            autocapitalize="none" spellcheck="false" required />
          ${this.roleButtons(this.role, (r) => (this.role = r), "new-role")}
          <input name="new-password" data-testid="new-password" type="password"
            autocomplete="new-password" placeholder=${t("auth.password")} required />
          <input name="confirm-user" data-testid="confirm-user" type="password"
            autocomplete="current-password" placeholder=${t("users.your_password")} required />
          <button class="primary" type="submit" data-testid="add-user"
            ${makes(request("POST", "/api/auth/users"))}>${t("users.add")}</button>
        </form>
      </section>
      <h2>${t("users.tokens")}</h2>
      <section class="card">
        <table data-testid="tokens">
          ${this.tokens.map(
            (k) => html`<tr data-testid="token"><td translate="no">${k.name}</td>
              <td>${t(`auth.role.${k.role}`)}</td></tr>`,
          )}
        </table>
        <form @submit=${this.addToken}>
          <input name="token-name" data-testid="token-name" placeholder=${t("users.token_name")} required />
          ${this.roleButtons(this.tokenRole, (r) => (this.tokenRole = r), "token-role")}
          <input name="confirm-token" type="password" autocomplete="current-password"
            placeholder=${t("users.your_password")} required />
          <button type="submit" data-testid="add-token" ${makes(request("POST", "/api/auth/tokens"))}>${t("users.add_token")}</button>
        </form>
        ${this.newToken
          ? html`<p>${t("users.token_once")}</p><p class="token" data-testid="new-token">${this.newToken}</p>`
          : ""}
      </section>
      <h2>${t("users.audit")}</h2>
      <section class="card">
        <a class="button" href="/api/auth/audit/export" download data-testid="audit-export"
          >${t("users.audit_export")}</a>
        <div class="audit">
          <table data-testid="audit">
            ${this.audit.map(
              (a) => html`<tr data-testid="audit-entry">
                <td>${new Date(a.ts * 1000).toLocaleString()}</td>
                <td translate="no">${a.user}</td>
                <td translate="no">${a.action} ${a.target}</td>
                <td>${a.status}</td>
                <td translate="no">${a.address}</td>
              </tr>`,
            )}
          </table>
        </div>
      </section>
    `;
  }
}

customElements.define("op-users-panel", OpUsersPanel);
