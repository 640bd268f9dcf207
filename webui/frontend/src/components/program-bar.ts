import { LitElement, css, html, nothing } from "lit";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
import type { ProgramSummary } from "../program/types";

export type ProgramAction =
  | "new" | "save" | "rename" | "duplicate" | "delete" | "undo" | "redo";

// The Program panel's top bar: which program (a dropdown of the saved ones), unsaved or not,
// new, save, rename, duplicate, delete, export (a download of the saved program's file: once
// its changes are saved),
// import (a file chosen on the tablet), undo and redo. Emits program-open {name},
// program-action {action} and program-import {file}; the panel acts.
export class OpProgramBar extends LitElement {
  static properties = {
    programs: { attribute: false },
    name: { type: String },
    dirty: { type: Boolean },
    canSave: { type: Boolean },
    live: { type: Boolean },
    undo: { type: Boolean },
    redo: { type: Boolean },
  };
  declare programs: ProgramSummary[];
  declare name: string; // "" until a new program is first saved
  declare dirty: boolean;
  declare canSave: boolean;
  declare live: boolean; // a run of it is under way: no rename, no delete
  declare undo: boolean;
  declare redo: boolean;

  static styles = [
    shared,
    css`
      :host {
        display: flex;
        flex-wrap: wrap;
        gap: 8px;
        align-items: center;
      }
      button {
        padding: 0 16px;
      }
      select {
        min-height: var(--touch);
        min-width: 180px;
        max-width: 320px;
        padding: 0 12px;
        border-radius: 10px;
        border: 2px solid var(--line);
        background: var(--bg);
        color: var(--text);
        font: inherit;
      }
      .spacer {
        flex: 1;
      }
      a.button {
        padding: 0 16px;
      }

      .dirty {
        color: var(--warn);
        font-size: 15px;
      }
      /* Undo and redo by their arrows alone (named for screen readers), so that the bar's
         ten controls fit one row on a 1280 px tablet. */
      @media (max-width: 1500px) {
        .label {
          display: none;
        }
        :host {
          gap: 6px;
        }
        button,
        a.button {
          padding: 0 12px;
        }
        select {
          min-width: 120px;
        }
      }
      @media (max-width: 700px) {
        button {
          padding: 0 12px;
        }
        select {
          min-width: 0;
          flex: 1;
        }
      }
    `,
  ];

  constructor() {
    super();
    this.programs = [];
    this.name = "";
    this.dirty = false;
    this.canSave = false;
    this.live = false;
    this.undo = false;
    this.redo = false;
  }

  updated(): void {
    // After the options render: a value set before its option exists would not hold.
    const select = this.renderRoot.querySelector<HTMLSelectElement>("[data-testid=program-select]");
    if (select && select.value !== this.name) select.value = this.name;
  }

  private emit(action: ProgramAction): void {
    this.dispatchEvent(new CustomEvent("program-action", { detail: { action } }));
  }

  render() {
    // A new program's name is asked when it is saved: its path is any program's.
    const program = `/api/programs/${encodeURIComponent(this.name || "new")}`;
    return html`<select
        data-testid="program-select"
        aria-label=${t("program.program")}
        @change=${(e: Event) => {
          const select = e.target as HTMLSelectElement;
          const wanted = select.value;
          select.value = this.name; // until the panel has opened it
          this.dispatchEvent(new CustomEvent("program-open", { detail: { name: wanted } }));
        }}
      >
        ${this.name ? nothing : html`<option value="">${t("program.new_program")}</option>`}
        ${this.programs.map(
          (p) => html`<option value=${p.name} ?selected=${p.name === this.name}>${p.name}</option>`,
        )}
      </select>
      ${this.dirty
        ? html`<span class="dirty" data-testid="unsaved">${t("program.unsaved")}</span>`
        : nothing}
      <button data-testid="new" @click=${() => this.emit("new")}>${t("program.new")}</button>
      <button data-testid="save" class=${this.dirty || !this.name ? "primary" : ""}
        ?disabled=${!this.canSave} @click=${() => this.emit("save")}
        ${makes(request("PUT", program))}>${t("program.save")}</button>
      <button data-testid="rename" ?disabled=${!this.name || this.live}
        ${makes(request("POST", `${program}/rename`))}
        @click=${() => this.emit("rename")}>${t("program.rename")}</button>
      <button data-testid="duplicate" ?disabled=${!this.name}
        ${makes(request("POST", `${program}/duplicate`))}
        @click=${() => this.emit("duplicate")}>${t("program.duplicate")}</button>
      <button data-testid="delete" class="danger" ?disabled=${!this.name || this.live}
        ${makes(request("DELETE", program))}
        @click=${() => this.emit("delete")}>${t("program.delete")}</button>
      ${this.name && !this.dirty
        ? html`<a class="button" data-testid="export" href=${`${program}/file`} download
            >${t("program.export")}</a>`
        : html`<button data-testid="export" disabled>${t("program.export")}</button>`}
      <button data-testid="import" ${makes(request("PUT", `${program}/file`))}
        @click=${() => this.renderRoot.querySelector<HTMLInputElement>("[data-testid=import-file]")
          ?.click()}>${t("program.import")}</button>
      <input type="file" hidden data-testid="import-file" accept=".json,application/json"
        @change=${(e: Event) => {
          const input = e.target as HTMLInputElement;
          const file = input.files?.[0];
          input.value = ""; // the same file chosen again is a change again
          if (file) this.dispatchEvent(new CustomEvent("program-import", { detail: { file } }));
        }} />
      <span class="spacer"></span>
      <button data-testid="undo" aria-label=${t("program.undo")} ?disabled=${!this.undo}
        @click=${() => this.emit("undo")}>↶<span class="label"> ${t("program.undo")}</span>
      </button>
      <button data-testid="redo" aria-label=${t("program.redo")} ?disabled=${!this.redo}
        @click=${() => this.emit("redo")}>↷<span class="label"> ${t("program.redo")}</span>
      </button>`;
  }
}

customElements.define("op-program-bar", OpProgramBar);
