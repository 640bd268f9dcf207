import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { type Request, makes } from "../rights";
import { shared } from "../styles";
import "./modal";

const NAME = /^[A-Za-z][A-Za-z0-9_.-]{0,127}$/;

// Ask for a variable name (teach, rename); shows a server error such as "exists" in place.
export class OpNameDialog extends LitElement {
  static properties = {
    heading: { type: String },
    value: { type: String },
    tags: { type: String },
    confirmLabel: { type: String },
    error: { type: String },
    busy: { type: Boolean },
    requests: { attribute: false },
  };
  declare heading: string;
  declare value: string;
  // Comma-separated; null: no tags field. A string, not an array: Lit re-applies array
  // bindings on every render of the parent, which would undo the typing.
  declare tags: string | null;
  declare confirmLabel: string; // "": the catalogue's "Save"
  declare error: string;
  declare busy: boolean;
  declare requests: Request[]; // what confirming asks the runtime

  static styles = [
    shared,
    css`
      .actions {
        display: flex;
        gap: 12px;
        justify-content: flex-end;
        margin-top: 16px;
      }
      .hint {
        font-size: 15px;
        margin-top: 6px;
      }
    `,
  ];

  constructor() {
    super();
    this.heading = "";
    this.value = "";
    this.tags = null;
    this.confirmLabel = "";
    this.error = "";
    this.busy = false;
    this.requests = [];
  }

  firstUpdated(): void {
    const input = this.renderRoot.querySelector("input");
    input?.focus();
    input?.select();
  }

  private submit(e: Event) {
    e.preventDefault();
    if (!NAME.test(this.value) || this.busy) return;
    const tags = (this.tags ?? "").split(",").map((tag) => tag.trim()).filter(Boolean);
    this.dispatchEvent(new CustomEvent("confirm", { detail: { name: this.value, tags } }));
  }

  render() {
    const valid = NAME.test(this.value);
    const confirm = this.confirmLabel || t("program.name_dialog.save");
    return html`<op-modal heading=${this.heading}>
      <form @submit=${this.submit}>
        <input
          data-testid="name-input"
          aria-label=${t("program.name_dialog.name")}
          autocapitalize="none"
          spellcheck="false"
          .value=${this.value}
          @input=${(e: InputEvent) => (this.value = (e.target as HTMLInputElement).value.trim())}
        />
        <div class="hint ${valid ? "muted" : "error"}">
          ${t("program.name_dialog.rule")}
        </div>
        ${this.tags === null
          ? ""
          : html`<input
              data-testid="tags-input"
              aria-label=${t("program.name_dialog.tags")}
              placeholder=${t("program.name_dialog.tags_placeholder")}
              autocapitalize="none"
              style="margin-top:12px"
              .value=${this.tags}
              @input=${(e: InputEvent) => (this.tags = (e.target as HTMLInputElement).value)}
            />`}
        ${this.error ? html`<p class="error" role="alert">${this.error}</p>` : ""}
        <div class="actions">
          <button type="button" @click=${() => this.dispatchEvent(new CustomEvent("close"))}>
            ${t("program.name_dialog.cancel")}
          </button>
          <button class="primary" type="submit" data-testid="name-confirm"
            ?disabled=${!valid || this.busy} ${makes(...this.requests)}>${confirm}</button>
        </div>
      </form>
    </op-modal>`;
  }
}

customElements.define("op-name-dialog", OpNameDialog);
