import { LitElement, css, html, nothing } from "lit";
import { t } from "../i18n";
import { type Request, makes, request } from "../rights";
import { shared } from "../styles";
import "./modal";
import "./name-dialog";

export type ProgramDialogKind = "new" | "rename" | "duplicate" | "delete" | "import";

// The Program panel's dialogs: the name of a new program, a rename, a duplicate, an
// imported file's, and the question before a delete; the server's refusal shows in place. Emits program-name {name},
// program-delete and close; the panel acts.
export class OpProgramDialog extends LitElement {
  static properties = {
    kind: { type: String },
    name: { type: String },
    error: { type: String },
    busy: { type: Boolean },
  };
  declare kind: ProgramDialogKind;
  declare name: string; // the program's
  declare error: string;
  declare busy: boolean;

  static styles = [
    shared,
    css`
      .actions {
        display: flex;
        gap: 12px;
        justify-content: flex-end;
        margin-top: 16px;
      }
    `,
  ];

  constructor() {
    super();
    this.kind = "new";
    this.name = "";
    this.error = "";
    this.busy = false;
  }

  /** One close event, whether the sheet (Escape, the backdrop) or a Cancel button sent it. */
  private close = (e?: Event) => {
    e?.stopPropagation();
    this.dispatchEvent(new CustomEvent("close"));
  };

  /** What confirming the dialog asks the runtime (a new program's name is typed in it: its
   * path is any program's). */
  private requests(): Request[] {
    const program = `/api/programs/${encodeURIComponent(this.name || "new")}`;
    if (this.kind === "rename") return [request("POST", `${program}/rename`)];
    if (this.kind === "duplicate") return [request("POST", `${program}/duplicate`)];
    if (this.kind === "delete") return [request("DELETE", program)];
    if (this.kind === "import") return [request("PUT", `${program}/file`)];
    return [request("PUT", program)];
  }

  render() {
    if (this.kind === "delete") {
      return html`<op-modal heading=${t("program.delete_heading", { name: this.name })}
        @close=${this.close}>
        <p>${t("program.delete_text")}</p>
        ${this.error ? html`<p class="error" role="alert">${this.error}</p>` : nothing}
        <div class="actions">
          <button @click=${() => this.close()}>${t("program.cancel")}</button>
          <button class="danger" data-testid="delete-confirm" ?disabled=${this.busy}
            ${makes(...this.requests())}
            @click=${() => this.dispatchEvent(new CustomEvent("program-delete"))}>
            ${t("program.delete")}</button>
        </div>
      </op-modal>`;
    }
    const heading = {
      new: t("program.save_new_heading"),
      rename: t("program.rename_heading", { name: this.name }),
      duplicate: t("program.duplicate_heading", { name: this.name }),
      import: t("program.import_heading"),
    }[this.kind];
    return html`<op-name-dialog
      heading=${heading}
      value=${this.kind === "duplicate" ? `${this.name}_copy` : this.name}
      confirmLabel=${this.kind === "duplicate" ? t("program.duplicate")
        : this.kind === "import" ? t("program.import") : t("program.save")}
      error=${this.error}
      ?busy=${this.busy}
      .requests=${this.requests()}
      @confirm=${(e: CustomEvent<{ name: string }>) => this.dispatchEvent(
        new CustomEvent("program-name", { detail: { name: e.detail.name } }))}
      @close=${this.close}
    ></op-name-dialog>`;
  }
}

customElements.define("op-program-dialog", OpProgramDialog);
