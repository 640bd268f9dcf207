// What the Program panel's bar and dialogs do with programs: open one (asking before
// unsaved blocks are dropped), start a new one, save (a new program asks for its name
// first), rename, duplicate, delete, import a program file (its name asked, the file's to
// start with; replacing a program asks first, and its old version stays in its history). What they show goes on the panel: busy, the notice, the
// dialog and its error, and the Python tab when a save fails.

import { ApiError, type Schemas, errorText } from "../api";
import { t } from "../i18n";
import type { ProgramAction } from "../components/program-bar";
import type { ProgramDialogKind } from "../components/program-dialog";
import type { Tab } from "../components/program-side";
import type { ProgramDocument } from "./document";
import type { ProgramRunner } from "./runner";

const PROGRAM_NAME = /^[A-Za-z][A-Za-z0-9_-]{0,63}$/;

/** The panel's state these change. */
export interface FilesView {
  busy: boolean;
  notice: string;
  dialog: ProgramDialogKind | null;
  dialogError: string;
  tab: Tab;
}

/** The largest program file the runtime takes (runtime/program/program_file.py). */
const MAX_FILE_BYTES = 8 * 1024 * 1024;

type ProgramFile = Schemas["ProgramFile"];

export class ProgramFiles {
  private imported: ProgramFile | null = null;

  constructor(
    private readonly view: FilesView,
    private readonly doc: ProgramDocument,
    private readonly runner: ProgramRunner,
  ) {}

  async open(name: string): Promise<void> {
    if (!this.doc.editor || !(await this.confirmDiscard())) return;
    try {
      await this.doc.open(name);
      this.view.notice = "";
      this.runner.forget();
      await this.runner.fetchStatus(name);
    } catch (err) {
      this.view.notice = errorText(err);
    }
  }

  startNew(): void {
    if (!this.doc.editor) return;
    this.doc.startNew();
    this.runner.forget();
  }

  private async confirmDiscard(): Promise<boolean> {
    return !this.doc.dirty || window.confirm(t("program.discard_confirm"));
  }

  /** Saves the blocks; a new program asks for its name first. True when saved. */
  async save(): Promise<boolean> {
    if (!this.doc.editor || this.doc.source !== "blocks") return false;
    if (!this.doc.name) {
      this.view.dialog = "new";
      return false;
    }
    return this.saveAs(this.doc.name);
  }

  private async saveAs(name: string): Promise<boolean> {
    if (!this.doc.editor) return false;
    this.view.busy = true;
    try {
      await this.doc.saveAs(name);
      this.view.notice = "";
      await this.doc.listPrograms();
      return true;
    } catch (err) {
      this.view.notice = t("program.not_saved", { error: errorText(err) });
      this.view.tab = "python";
      return false;
    } finally {
      this.view.busy = false;
    }
  }

  /** The bar's buttons. */
  async act(action: ProgramAction): Promise<void> {
    if (action === "new") {
      if (await this.confirmDiscard()) this.startNew();
    } else if (action === "save") {
      await this.save();
    } else if (action === "undo" || action === "redo") {
      this.doc.editor?.undo(action === "redo");
    } else {
      this.view.dialogError = "";
      this.view.dialog = action;
    }
  }

  /** The name the import dialog starts with: the program's where it was exported. */
  get importName(): string {
    return this.imported?.name ?? "";
  }

  /** A file chosen on the tablet: read, then its name asked in the import dialog. */
  async chooseFile(file: File): Promise<void> {
    try {
      if (file.size > MAX_FILE_BYTES) throw new Error(t("program.file_too_large"));
      const parsed: unknown = JSON.parse(await file.text());
      if (typeof parsed !== "object" || parsed === null || !("format" in parsed)) {
        throw new Error(t("program.not_a_file"));
      }
      // The runtime checks the rest when it is saved.
      this.imported = parsed as ProgramFile;
      this.view.dialogError = "";
      this.view.dialog = "import";
    } catch (err) {
      this.view.notice = t("program.not_imported", { error: errorText(err) });
    }
  }

  private async importAs(name: string): Promise<void> {
    if (!this.imported) return;
    await this.doc.listPrograms(); // made meanwhile on another pendant: asked about too
    const exists = this.doc.programs.some((p) => p.name === name);
    if (exists && !window.confirm(t("program.replace_confirm", { name }))) return;
    // What is on show is dropped for the file's: asked before anything is saved.
    if (!(await this.confirmDiscard())) return;
    const imported = await this.doc.importFile(name, this.imported);
    this.imported = null;
    this.view.dialog = null;
    this.doc.dirty = false;
    await this.open(name);
    if (imported.generated_as_in_file === false && !this.view.notice) {
      this.view.notice = t("program.imported_regenerated", { name });
    }
  }

  /** The name given in the dialog open: of a new program, a rename, a duplicate, an import. */
  async nameChosen(name: string): Promise<void> {
    const view = this.view;
    if (!PROGRAM_NAME.test(name)) {
      view.dialogError = t("program.name_rule");
      return;
    }
    const dialog = view.dialog;
    const exists = this.doc.programs.some((p) => p.name === name);
    view.busy = true;
    try {
      if (dialog === "new") {
        if (exists) throw new ApiError(t("program.exists", { name }), "exists", 409);
        if (!(await this.saveAs(name))) throw new Error(view.notice);
      } else if (dialog === "rename") {
        await this.doc.rename(name);
      } else if (dialog === "duplicate") {
        if (this.doc.dirty && !(await this.saveAs(this.doc.name))) throw new Error(view.notice);
        await this.doc.duplicate(name);
        await this.open(name);
      } else if (dialog === "import") {
        await this.importAs(name);
        return;
      }
      view.dialog = null;
    } catch (err) {
      view.dialogError = errorText(err);
    } finally {
      view.busy = false;
    }
  }

  /** Deletes the program on show; the first one left opens instead. */
  async remove(): Promise<void> {
    const view = this.view;
    view.busy = true;
    try {
      await this.doc.remove();
      view.dialog = null;
      await this.doc.listPrograms();
      if (this.doc.programs.length > 0) await this.open(this.doc.programs[0].name);
      else this.startNew();
    } catch (err) {
      view.dialogError = errorText(err);
    } finally {
      view.busy = false;
    }
  }
}
