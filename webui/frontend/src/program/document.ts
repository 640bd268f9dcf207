// The program on show in the Program panel and the list of programs saved: its name, its
// blocks (on the editor), the Python they make and what keeps them from running (previewed
// as they change), saved or not. Open, start anew, save, rename, duplicate, delete. Errors
// are thrown: the panel says them. What is on the editor when the panel is left comes back
// as it was when the panel is shown again.

import type { ReactiveController, ReactiveControllerHost } from "lit";
import { type Schemas, client, errorText, ok } from "../api";
import { session } from "../session";
import type { ProgramEditor } from "./editor";
import type { Problem, ProgramSummary } from "./types";

const PREVIEW_DELAY_MS = 400;

interface Draft {
  name: string;
  state: object;
  saved: string;
  breakpoints: string[];
}
let draft: Draft | null = null;

export class ProgramDocument implements ReactiveController {
  programs: ProgramSummary[] = [];
  name = ""; // "" until a new program is first saved
  source: "blocks" | "python" = "blocks";
  python = "";
  problem = ""; // why the blocks do not generate, if they do not
  problems: Problem[] = []; // what keeps them from running (empty inputs, loose blocks)
  dirty = false;
  editor: ProgramEditor | null = null; // once Blockly has loaded
  private saved = "";
  private previewTimer = 0;
  private previewing = 0;

  constructor(private readonly host: ReactiveControllerHost) {
    host.addController(this);
  }

  hostDisconnected(): void {
    window.clearTimeout(this.previewTimer);
    if (this.editor) {
      draft = {
        name: this.name,
        state: this.editor.state(),
        saved: this.saved,
        breakpoints: [...this.editor.breakpoints],
      };
      this.editor.dispose();
      this.editor = null;
    }
  }

  /** Puts back what was on the editor when the panel was left; its name, or null if none. */
  restore(): string | null {
    if (!draft || !this.editor) return null;
    const kept = draft;
    draft = null;
    this.name = kept.name;
    this.editor.load(kept.state);
    this.saved = kept.saved;
    for (const id of kept.breakpoints) this.editor.toggleBreakpoint(id);
    this.source = "blocks";
    this.blocksChanged();
    this.host.requestUpdate();
    return kept.name;
  }

  async listPrograms(): Promise<void> {
    this.programs = await ok(client.GET("/api/programs"));
    this.host.requestUpdate();
  }

  async open(name: string): Promise<void> {
    if (!this.editor) return;
    const program = await ok(client.GET("/api/programs/{name}", { params: { path: { name } } }));
    this.name = program.name;
    this.source = program.source;
    this.editor.load(program.source === "blocks" ? program.workspace : null);
    this.saved = JSON.stringify(this.editor.state());
    this.python = program.python;
    this.problem = "";
    this.showProblems([]);
    this.dirty = false;
    this.host.requestUpdate();
    if (program.source === "blocks") void this.preview(); // its problems, if any
  }

  startNew(): void {
    if (!this.editor) return;
    this.name = "";
    this.source = "blocks";
    this.editor.load(null);
    this.saved = JSON.stringify(this.editor.state());
    this.python = "";
    this.problem = "";
    this.dirty = false;
    this.host.requestUpdate();
  }

  /** Saves the blocks under this name (the program's own, or the name of a new one). */
  async saveAs(name: string): Promise<void> {
    if (!this.editor) return;
    const state = this.editor.state();
    const saved = await ok(client.PUT("/api/programs/{name}", {
      params: { path: { name } },
      body: { workspace: state },
    }));
    this.name = saved.name;
    this.saved = JSON.stringify(state);
    this.dirty = JSON.stringify(this.editor.state()) !== this.saved;
    this.python = saved.python;
    this.problem = "";
    this.showProblems(saved.problems);
    this.host.requestUpdate();
  }

  async rename(to: string): Promise<void> {
    await ok(client.POST("/api/programs/{name}/rename",
      { params: { path: { name: this.name } }, body: { to } }));
    this.name = to;
    await this.listPrograms();
  }

  /** A copy of the program as saved, under another name; this one stays on show. */
  async duplicate(to: string): Promise<void> {
    await ok(client.POST("/api/programs/{name}/duplicate",
      { params: { path: { name: this.name } }, body: { to } }));
    await this.listPrograms();
  }

  /** A program file (as exported) saved under `name`: the runtime checks it as a save. */
  async importFile(name: string, file: Schemas["ProgramFile"]): Promise<Schemas["ProgramImported"]> {
    const imported = await ok(client.PUT("/api/programs/{name}/file",
      { params: { path: { name } }, body: file }));
    await this.listPrograms();
    return imported;
  }

  async remove(): Promise<void> {
    await ok(client.DELETE("/api/programs/{name}", { params: { path: { name: this.name } } }));
    this.dirty = false;
    this.host.requestUpdate();
  }

  /** The blocks changed: unsaved or not, and their Python a moment later. */
  blocksChanged(): void {
    if (!this.editor) return;
    const dirty = JSON.stringify(this.editor.state()) !== this.saved;
    if (dirty !== this.dirty) {
      this.dirty = dirty;
      this.host.requestUpdate();
    }
    window.clearTimeout(this.previewTimer);
    this.previewTimer = window.setTimeout(() => void this.preview(), PREVIEW_DELAY_MS);
  }

  /** The Python of the blocks as they are now, or why there is none. */
  private async preview(): Promise<void> {
    if (!this.editor || this.source !== "blocks") return;
    // Generating is a programmer's: an operator's Python is the saved program's.
    if (!session.may("POST", "/api/programs/_generate")) return;
    const ticket = ++this.previewing;
    try {
      const generated = await ok(client.POST("/api/programs/_generate", {
        body: { workspace: this.editor.state() },
      }));
      if (ticket !== this.previewing) return;
      this.python = generated.python;
      this.problem = "";
      this.showProblems(generated.problems);
    } catch (err) {
      if (ticket === this.previewing) this.problem = errorText(err);
    }
    this.host.requestUpdate();
  }

  /** Warnings on the blocks, and the list under the run buttons; Run waits until none. */
  private showProblems(problems: Problem[]): void {
    this.problems = problems;
    this.editor?.warn(problems);
  }
}
