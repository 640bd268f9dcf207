import { LitElement, css, html, nothing } from "lit";
import { client, errorText, ok } from "../api";
import { FocusController, focus } from "../focus";
import { t } from "../i18n";
import { Listening } from "../listening";
import { FeedController, feed } from "../live";
import { shared } from "../styles";
import { RobotLoader } from "../robot-loader";
import type { RobotModel } from "../components/robot-view";
import type { ProgramAction } from "../components/program-bar";
import type { ProgramDialogKind } from "../components/program-dialog";
import type { Tab } from "../components/program-side";
import { blocklyStyles } from "../program/blockly-styles";
import type { BlockCatalog } from "../program/catalog";
import { refreshChoices, waypointFeed } from "../program/choices";
import { ProgramDocument } from "../program/document";
import { ProgramFiles } from "../program/files";
import { type RunCommand, ProgramRunner } from "../program/runner";
import "../components/program-bar";
import "../components/program-dialog";
import "../components/program-side";
import "../components/run-controls";

const NONE: never[] = [];

// Programs as blocks: edit, save and load, run with the running block highlighted, pause,
// step, stop, breakpoints, the output and the generated Python. The program and its list
// are in ProgramDocument, what the bar and dialogs do with them in ProgramFiles, its runs in
// ProgramRunner; this panel loads the editor, lays it all out and says what went wrong.
export class OpProgramPanel extends LitElement {
  static properties = {
    loading: { state: true },
    busy: { state: true },
    notice: { state: true },
    dialog: { state: true },
    dialogError: { state: true },
    tab: { state: true },
    history: { state: true },
    selected: { state: true },
    model: { state: true },
  };
  declare loading: boolean;
  declare busy: boolean;
  declare notice: string;
  declare dialog: ProgramDialogKind | null;
  declare dialogError: string;
  declare tab: Tab;
  declare model: RobotModel | null; // the robot in focus, for the 3D tab
  declare history: { undo: boolean; redo: boolean };
  declare selected: string | null;

  private readonly doc = new ProgramDocument(this);
  private readonly runner = new ProgramRunner(this, () => this.doc.name, () => this.doc.editor);
  private readonly files = new ProgramFiles(this, this.doc, this.runner);

  static styles = [
    shared,
    blocklyStyles,
    css`
      :host {
        display: grid;
        grid-template-rows: auto 1fr;
        gap: 10px;
        height: 100%;
        min-height: 0;
      }
      .work {
        display: grid;
        grid-template-columns: minmax(0, 1fr) 360px;
        gap: 10px;
        min-height: 0;
      }
      .blockly {
        position: relative;
        min-height: 0;
        border: 1px solid var(--line);
        border-radius: 12px;
        overflow: hidden;
      }
      .blockly .host {
        position: absolute;
        inset: 0;
      }
      .blockly .cover {
        position: absolute;
        inset: 0;
        display: flex;
        align-items: center;
        justify-content: center;
        text-align: center;
        padding: 24px;
        background: var(--bg);
      }
      .side {
        display: flex;
        flex-direction: column;
        gap: 8px;
        min-height: 0;
      }
      @media (max-width: 700px) {
        :host {
          height: auto;
        }
        .work {
          grid-template-columns: minmax(0, 1fr);
        }
        .blockly {
          height: 62vh;
        }
      }
    `,
  ];

  constructor() {
    super();
    new Listening(this, window, "beforeunload", this.onUnload as EventListener);
    this.loading = true;
    this.busy = false;
    this.notice = "";
    this.dialog = null;
    this.dialogError = "";
    this.tab = "output";
    this.model = null;
    this.history = { undo: false, redo: false };
    this.selected = null;
    new FeedController(this);
    new FocusController(this);
    new RobotLoader(this, (robot) => this.loadModel(robot), () => this.tab === "view");
  }

  private onUnload = (event: BeforeUnloadEvent) => {
    if (this.doc.dirty) event.preventDefault();
  };

  connectedCallback(): void {
    super.connectedCallback();
    waypointFeed.start();
  }

  disconnectedCallback(): void {
    waypointFeed.stop();
    super.disconnectedCallback(); // the document keeps what is on the editor
  }

  async firstUpdated(): Promise<void> {
    try {
      const [{ ProgramEditor }, catalog] = await Promise.all([
        import("../program/editor"),
        // Blockly's JSON: the runtime types it as JSON objects, Blockly's types say more.
        ok(client.GET("/api/programs/_blocks")).then((c) => c as unknown as BlockCatalog),
        refreshChoices().catch(() => undefined),
      ]);
      const host = this.renderRoot.querySelector<HTMLElement>(".host");
      if (!host || !this.isConnected) return;
      const editor = new ProgramEditor(host, catalog, window.innerWidth < 700);
      this.doc.editor = editor;
      editor.addEventListener("blocks", () => {
        if (this.tab === "outline") this.requestUpdate();
        this.doc.blocksChanged();
      });
      editor.addEventListener("history", () => {
        this.history = { undo: editor.canUndo(), redo: editor.canRedo() };
      });
      editor.addEventListener("selection", () => (this.selected = editor.selectedBlock()));
      editor.addEventListener("breakpoints", () => {
        this.requestUpdate();
        void this.runner.syncBreakpoints().catch((err: unknown) => (this.notice = errorText(err)));
      });
      await this.doc.listPrograms();
      const kept = this.doc.restore();
      if (kept !== null) {
        if (kept) await this.runner.fetchStatus(kept);
      } else if (this.doc.programs.length > 0) {
        await this.files.open(this.doc.programs[0].name);
      } else {
        this.files.startNew();
      }
    } catch (err) {
      this.notice = t("program.editor_failed", { error: errorText(err) });
    } finally {
      this.loading = false;
    }
  }

  private async loadModel(robot: string): Promise<boolean> {
    try {
      const model = await ok(client.GET("/api/jog/robots/{robot}", { params: { path: { robot } } }));
      if (robot === focus.robot) this.model = model;
      return true;
    } catch {
      return false;
    }
  }

  // --- running ----------------------------------------------------------------------------

  private async run(): Promise<void> {
    const doc = this.doc;
    if (!doc.editor) return;
    const unsaved = doc.source === "blocks" && (doc.dirty || !doc.name);
    if (unsaved && !(await this.files.save())) return;
    this.busy = true;
    try {
      await this.runner.start();
      this.notice = "";
      this.tab = "output";
    } catch (err) {
      this.notice = t("program.not_started", { error: errorText(err) });
    } finally {
      this.busy = false;
    }
  }

  private async command(action: RunCommand): Promise<void> {
    try {
      await this.runner.command(action);
    } catch (err) {
      this.notice = errorText(err);
    }
  }

  // --- view -------------------------------------------------------------------------------

  private reveal = (e: CustomEvent<{ block: string }>) => this.doc.editor?.reveal(e.detail.block);

  render() {
    const doc = this.doc;
    const editor = doc.editor;
    const blocks = doc.source === "blocks";
    const view = this.runner.view();
    const status = view?.status ?? null;
    const live = this.runner.live();
    const robot = focus.robot;
    const selected = this.selected;
    const joints = this.tab === "view" && this.model?.name === robot
      ? feed.states.get(robot)?.joint_position ?? null : null;
    return html`
      <op-program-bar .programs=${doc.programs} name=${doc.name} ?dirty=${doc.dirty}
        ?canSave=${blocks && !this.busy} ?live=${live}
        ?undo=${this.history.undo} ?redo=${this.history.redo}
        @program-open=${(e: CustomEvent<{ name: string }>) => void this.files.open(e.detail.name)}
        @program-action=${(e: CustomEvent<{ action: ProgramAction }>) =>
          void this.files.act(e.detail.action)}
        @program-import=${(e: CustomEvent<{ file: File }>) => void this.files.chooseFile(e.detail.file)}
      ></op-program-bar>
      <div class="work">
        <div class="blockly">
          <div class="host" data-testid="workspace"></div>
          ${this.loading
            ? html`<div class="cover" role="progressbar" aria-label=${t("program.loading_editor")}>
                ${t("program.loading_block_editor")}</div>`
            : nothing}
          ${!this.loading && !blocks
            ? html`<div class="cover">
                <p>${t("program.python_only", { name: doc.name })}</p>
              </div>`
            : nothing}
        </div>
        <div class="side">
          <op-run-controls program=${doc.name} .status=${status} .selected=${selected}
            ?runnable=${!(this.busy || this.loading
              || (blocks && (doc.problem !== "" || doc.problems.length > 0)))}
            ?breakpoint=${selected !== null && !!editor?.breakpoints.has(selected)}
            block=${status?.block && live ? editor?.describe(status.block) ?? "" : ""}
            robot=${robot} ?robots=${feed.robots().length > 0} notice=${this.notice}
            .problems=${blocks ? doc.problems : NONE}
            @run=${() => void this.run()}
            @run-command=${(e: CustomEvent<{ action: RunCommand }>) =>
              void this.command(e.detail.action)}
            @breakpoint-toggle=${() =>
              this.selected && this.doc.editor?.toggleBreakpoint(this.selected)}
            @reveal=${this.reveal}
          ></op-run-controls>
          <op-program-side tab=${this.tab} .status=${status} .output=${view?.output ?? NONE}
            .outline=${this.tab === "outline" ? editor?.outline() ?? NONE : NONE}
            .selected=${selected} .problems=${doc.problems} problem=${doc.problem}
            python=${doc.python} robot=${robot} .model=${this.model} .joints=${joints}
            @tab=${(e: CustomEvent<{ tab: Tab }>) => (this.tab = e.detail.tab)}
            @reveal=${this.reveal}
          ></op-program-side>
        </div>
      </div>
      ${this.dialog
        ? html`<op-program-dialog kind=${this.dialog}
            name=${this.dialog === "import" ? this.files.importName : doc.name} error=${this.dialogError}
            ?busy=${this.busy}
            @program-name=${(e: CustomEvent<{ name: string }>) => this.files.nameChosen(e.detail.name)}
            @program-delete=${() => this.files.remove()}
            @close=${() => (this.dialog = null)}
          ></op-program-dialog>`
        : nothing}
    `;
  }
}

customElements.define("op-program-panel", OpProgramPanel);
