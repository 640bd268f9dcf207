import { LitElement, css, html, nothing } from "lit";
import { api, ApiError, errorText } from "../api";
import { control } from "../control";
import { FocusController, focus } from "../focus";
import { type StringKey, t } from "../i18n";
import { FeedController, feed } from "../live";
import { shared } from "../styles";
import type { DeviceDetails } from "../types";
import { RobotLoader } from "../robot-loader";
import type { RobotModel } from "../components/robot-view";
import type { ProgramEditor } from "../program/editor";
import type { BlockCatalog } from "../program/catalog";
import { RunFeed } from "../program/run-feed";
import { type WaypointChange, WaypointFeed } from "../program/waypoint-feed";
import {
  LIVE_STATES,
  type Generated,
  type OutputEntry,
  type Problem,
  type Program,
  type ProgramSummary,
  type RunState,
  type RunStatus,
  type Saved,
} from "../program/types";
import "../components/modal";
import "../components/robot-view";
import "../components/name-dialog";

const PROGRAM_NAME = /^[A-Za-z][A-Za-z0-9_-]{0,63}$/;
const PREVIEW_DELAY_MS = 400;

type Dialog = null | "new" | "rename" | "duplicate" | "delete";

// What was on the editor when the panel was left: coming back shows it as it was.
interface Draft {
  name: string;
  state: object;
  saved: string;
  breakpoints: string[];
}
let draft: Draft | null = null;

const runs = new RunFeed();
const waypointFeed = new WaypointFeed(
  (change) => void applyWaypoint(change),
  () => void refreshChoices().catch(() => undefined),
);

async function applyWaypoint({ name, present }: WaypointChange): Promise<void> {
  const { choices } = await import("../program/catalog");
  const names = new Set(choices.waypoints);
  if (present) names.add(name);
  else names.delete(name);
  choices.waypoints = [...names];
}

/** The robot names and what each has, for the dropdowns of the robot and I/O blocks. */
async function refreshChoices(): Promise<void> {
  const { choices } = await import("../program/catalog");
  const robots = feed.robots().map((r) => r.local_name);
  choices.robots = robots;
  const details = await Promise.all(
    robots.map((r) =>
      api<DeviceDetails>("GET", `/api/devices/${encodeURIComponent(r)}`).catch(() => null),
    ),
  );
  const inputs: string[] = [];
  const outputs: string[] = [];
  for (const d of details) {
    const info = d?.info?.info;
    if (!d || !info) continue;
    for (let i = 0; i < (info.digital_inputs ?? 0); i++) inputs.push(`${d.local_name}.di${i}`);
    for (let i = 0; i < (info.digital_outputs ?? 0); i++) outputs.push(`${d.local_name}.do${i}`);
  }
  choices.inputs = inputs;
  choices.outputs = outputs;
  const lists = await Promise.all(
    ["joint_waypoint", "pose_waypoint"].map((type) =>
      api<{ name: string }[]>("GET", `/api/variables?type=${type}`).catch(() => []),
    ),
  );
  choices.waypoints = lists.flat().map((v) => v.name);
}

// Programs as blocks: edit, save and load, run with the running block highlighted, pause,
// step, stop, breakpoints, the output and the generated Python.
/** The Python as people read it: without the block markers the runtime runs it with. */
function readable(python: string): string {
  return python
    .split("\n")
    .filter((line) => !/^\s*at_block\(/.test(line))
    .join("\n");
}

export class OpProgramPanel extends LitElement {
  static properties = {
    programs: { state: true },
    name: { state: true },
    source: { state: true },
    python: { state: true },
    problem: { state: true },
    problems: { state: true },
    dirty: { state: true },
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
  declare programs: ProgramSummary[];
  declare name: string; // "" until a new program is first saved
  declare source: "blocks" | "python";
  declare python: string;
  declare problem: string; // why the blocks do not generate, if they do not
  declare problems: Problem[]; // what keeps them from running (empty inputs, loose blocks)
  declare dirty: boolean;
  declare loading: boolean;
  declare busy: boolean;
  declare notice: string;
  declare dialog: Dialog;
  declare dialogError: string;
  declare tab: Tab;
  declare model: RobotModel | null; // the robot in focus, for the 3D tab
  declare history: { undo: boolean; redo: boolean };
  declare selected: string | null;

  private editor: ProgramEditor | null = null;
  private saved = "";
  private previewTimer = 0;
  private previewing = 0;
  private highlighted: string | null = null;

  static styles = [
    shared,
    css`
      :host {
        display: grid;
        grid-template-rows: auto 1fr;
        gap: 10px;
        height: 100%;
        min-height: 0;
      }
      .bar {
        display: flex;
        flex-wrap: wrap;
        gap: 8px;
        align-items: center;
      }
      .bar button {
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
      .dirty {
        color: var(--warn);
        font-size: 15px;
      }
      button.run {
        background: var(--ok);
        border-color: var(--ok);
        color: var(--on-accent);
        min-height: 64px;
        font-size: 20px;
      }
      button.stop {
        background: var(--bad);
        border-color: var(--bad);
        color: #fff;
        min-height: 64px;
        font-size: 20px;
      }
      button.on {
        border-color: var(--bad);
        color: var(--bad-fg);
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
      .runpad {
        display: grid;
        grid-template-columns: 1fr 1fr;
        gap: 8px;
      }
      .runpad .wide {
        grid-column: span 2;
      }
      .tabs {
        display: flex;
        gap: 6px;
      }
      .tabs button {
        flex: 1 1 auto;
        padding: 0 6px; /* four tabs side by side, in German too */
        font-size: 16px;
        min-width: 0;
        white-space: nowrap;
        overflow: hidden;
        text-overflow: ellipsis;
      }
      .tabs button[aria-selected="true"] {
        border-color: var(--accent);
        color: var(--accent);
      }
      .pane {
        flex: 1;
        overflow: auto;
        min-height: 0;
        background: var(--panel);
        border: 1px solid var(--line);
        border-radius: 12px;
        padding: 10px;
        font-size: 15px;
      }
      pre {
        margin: 0;
        font: 14px/1.45 ui-monospace, "DejaVu Sans Mono", monospace;
        white-space: pre-wrap;
        overflow-wrap: anywhere;
      }
      /* Code never wraps: a wrapped line would seem to leave its loop. */
      pre.code {
        white-space: pre;
        overflow-wrap: normal;
        overflow-x: auto;
      }
      .line {
        display: block;
        width: 100%;
        min-height: 40px;
        padding: 6px 8px;
        text-align: left;
        font: 14px/1.4 ui-monospace, "DejaVu Sans Mono", monospace;
        font-weight: 400;
        border: none;
        border-bottom: 1px solid var(--line);
        border-radius: 0;
        background: transparent;
        white-space: pre-wrap;
        overflow-wrap: anywhere;
      }
      .line.stderr,
      .line.error {
        color: var(--error-fg);
      }
      .status {
        display: flex;
        flex-wrap: nowrap; /* one line whatever the block is called: nothing below jumps */
        gap: 8px;
        align-items: center;
        min-height: 36px;
        font-size: 15px;
      }
      .status > * {
        flex: none;
      }
      .status [data-testid="run-block"] {
        flex: 0 1 auto;
        min-width: 0;
        overflow: hidden;
        text-overflow: ellipsis;
        white-space: nowrap;
      }
      .outline .item {
        display: block;
        width: 100%;
        min-height: 44px;
        text-align: left;
        font-size: 15px;
        font-weight: 500;
        border: none;
        border-bottom: 1px solid var(--line);
        border-radius: 0;
        background: transparent;
        overflow-wrap: anywhere;
      }
      .outline .item.chosen {
        background: var(--raised);
      }
      .outline .item.running {
        box-shadow: inset 4px 0 0 var(--accent);
        color: var(--accent);
      }
      .view op-robot-view {
        height: 100%;
        min-height: 280px;
      }
      /* Blockly's dropdown menus: rows a finger can hit. */
      .blocklyDropDownDiv .blocklyMenuItem,
      .blocklyWidgetDiv .blocklyMenuItem {
        min-height: 48px;
        display: flex;
        align-items: center;
        font-size: 17px;
      }
      .problems {
        display: flex;
        flex-direction: column;
        gap: 6px;
        padding: 10px 12px;
        border: 2px solid var(--warn);
        border-radius: 12px;
      }
      button.problem {
        text-align: left;
        min-height: 48px;
        font-weight: 500;
        border-color: transparent;
        background: var(--panel);
      }
      .confirm {
        display: flex;
        gap: 12px;
        align-items: center;
        flex-wrap: wrap;
        padding: 10px 14px;
        border: 2px solid var(--accent);
        border-radius: 12px;
        background: var(--warn-bg);
      }
      .actions {
        display: flex;
        gap: 12px;
        justify-content: flex-end;
        margin-top: 16px;
      }
      /* Blockly draws inside this shadow root: its own CSS lands here, and so can ours. */
      .blocklyToolboxCategory {
        min-height: 46px;
        display: flex;
        align-items: center;
      }
      .blocklyToolboxCategoryLabel {
        font-size: 18px;
        padding: 0 10px;
      }
      .blocklyToolbox {
        min-width: 140px;
      }
      .opBreakpoint > .blocklyPath {
        stroke: #f85149 !important;
        stroke-width: 5px !important;
        stroke-dasharray: 8 4;
      }
      .blocklyHighlighted > .blocklyPath {
        stroke: #f5a524 !important;
        stroke-width: 6px !important;
      }
      @media (max-width: 700px) {
        :host {
          height: auto;
        }
        .work {
          grid-template-columns: minmax(0, 1fr);
        }
        .bar button {
          padding: 0 12px;
        }
        .bar .label {
          display: none;
        }
        .blockly {
          height: 62vh;
        }
        .pane {
          max-height: 40vh;
        }
        select {
          min-width: 0;
          flex: 1;
        }
        /* A narrow toolbox leaves the flyout room for the widest block (the pose). */
        .blocklyToolbox {
          min-width: 0;
          max-width: 112px;
        }
        .blocklyToolboxCategoryLabel {
          font-size: 15px;
          padding: 0 4px;
          white-space: normal;
          line-height: 1.15;
        }
      }
    `,
  ];

  constructor() {
    super();
    this.programs = [];
    this.name = "";
    this.source = "blocks";
    this.python = "";
    this.problem = "";
    this.problems = [];
    this.dirty = false;
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

  private onRuns = (event: Event) => {
    if ((event as CustomEvent<string>).detail === this.name) this.showRun();
  };

  private onUnload = (event: BeforeUnloadEvent) => {
    if (this.dirty) event.preventDefault();
  };

  connectedCallback(): void {
    super.connectedCallback();
    runs.addEventListener("change", this.onRuns);
    runs.start();
    waypointFeed.start();
    window.addEventListener("beforeunload", this.onUnload);
  }

  disconnectedCallback(): void {
    runs.removeEventListener("change", this.onRuns);
    runs.stop();
    waypointFeed.stop();
    window.removeEventListener("beforeunload", this.onUnload);
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
    super.disconnectedCallback();
  }

  async firstUpdated(): Promise<void> {
    try {
      const [{ ProgramEditor }, catalog] = await Promise.all([
        import("../program/editor"),
        api<BlockCatalog>("GET", "/api/programs/_blocks"),
        refreshChoices().catch(() => undefined),
      ]);
      const host = this.renderRoot.querySelector<HTMLElement>(".host");
      if (!host || !this.isConnected) return;
      const editor = new ProgramEditor(host, catalog, window.innerWidth < 700);
      this.editor = editor;
      editor.addEventListener("blocks", () => this.blocksChanged());
      editor.addEventListener("history", () => this.historyChanged());
      editor.addEventListener("selection", () => (this.selected = editor.selectedBlock()));
      editor.addEventListener("breakpoints", () => this.breakpointsChanged());
      await this.listPrograms();
      if (draft) {
        const kept = draft;
        draft = null;
        this.name = kept.name;
        editor.load(kept.state);
        this.saved = kept.saved;
        for (const id of kept.breakpoints) editor.toggleBreakpoint(id);
        this.source = "blocks";
        this.blocksChanged();
        if (kept.name) await this.fetchStatus(kept.name);
      } else if (this.programs.length > 0) {
        await this.open(this.programs[0].name);
      } else {
        this.startNew();
      }
    } catch (err) {
      this.notice = t("program.editor_failed", { error: errorText(err) });
    } finally {
      this.loading = false;
    }
  }

  updated(): void {
    // After the options render: a value set before its option exists would not hold.
    const select = this.renderRoot.querySelector<HTMLSelectElement>("[data-testid=program-select]");
    if (select && select.value !== this.name) select.value = this.name;
  }

  // --- programs ---------------------------------------------------------------------------

  private async listPrograms(): Promise<void> {
    this.programs = await api<ProgramSummary[]>("GET", "/api/programs");
  }

  private async open(name: string): Promise<void> {
    if (!this.editor || !(await this.confirmDiscard())) return;
    try {
      const program = await api<Program>("GET", `/api/programs/${encodeURIComponent(name)}`);
      this.name = program.name;
      this.source = program.source;
      this.editor.load(program.source === "blocks" ? program.workspace : null);
      this.saved = JSON.stringify(this.editor.state());
      this.python = program.python;
      this.problem = "";
      this.showProblems([]);
      this.dirty = false;
      this.notice = "";
      this.highlighted = null;
      if (program.source === "blocks") void this.preview(); // its problems, if any
      await this.fetchStatus(name);
    } catch (err) {
      this.notice = errorText(err);
    }
  }

  private startNew(): void {
    if (!this.editor) return;
    this.name = "";
    this.source = "blocks";
    this.editor.load(null);
    this.saved = JSON.stringify(this.editor.state());
    this.python = "";
    this.problem = "";
    this.dirty = false;
    this.highlighted = null;
  }

  private async confirmDiscard(): Promise<boolean> {
    return !this.dirty || window.confirm(t("program.discard_confirm"));
  }

  /** Saves the blocks; a new program asks for its name first. True when saved. */
  private async save(): Promise<boolean> {
    if (!this.editor || this.source !== "blocks") return false;
    if (!this.name) {
      this.dialog = "new";
      return false;
    }
    return this.saveAs(this.name);
  }

  private async saveAs(name: string): Promise<boolean> {
    if (!this.editor) return false;
    const state = this.editor.state();
    this.busy = true;
    try {
      const saved = await api<Saved>("PUT", `/api/programs/${encodeURIComponent(name)}`, {
        workspace: state,
      });
      this.name = saved.name;
      this.saved = JSON.stringify(state);
      this.dirty = JSON.stringify(this.editor.state()) !== this.saved;
      this.python = saved.python;
      this.problem = "";
      this.showProblems(saved.problems);
      this.notice = "";
      await this.listPrograms();
      return true;
    } catch (err) {
      this.notice = t("program.not_saved", { error: errorText(err) });
      this.tab = "python";
      return false;
    } finally {
      this.busy = false;
    }
  }

  private async nameChosen(name: string): Promise<void> {
    if (!PROGRAM_NAME.test(name)) {
      this.dialogError = t("program.name_rule");
      return;
    }
    const dialog = this.dialog;
    const exists = this.programs.some((p) => p.name === name);
    this.busy = true;
    try {
      if (dialog === "new") {
        if (exists) throw new ApiError(t("program.exists", { name }), "exists", 409);
        if (!(await this.saveAs(name))) throw new Error(this.notice);
      } else if (dialog === "rename") {
        await api("POST", `/api/programs/${encodeURIComponent(this.name)}/rename`, { to: name });
        this.name = name;
        await this.listPrograms();
      } else if (dialog === "duplicate") {
        if (this.dirty && !(await this.saveAs(this.name))) throw new Error(this.notice);
        await api("POST", `/api/programs/${encodeURIComponent(this.name)}/duplicate`, {
          to: name,
        });
        await this.listPrograms();
        await this.open(name);
      }
      this.dialog = null;
    } catch (err) {
      this.dialogError = errorText(err);
    } finally {
      this.busy = false;
    }
  }

  private async deleteProgram(): Promise<void> {
    const name = this.name;
    this.busy = true;
    try {
      await api("DELETE", `/api/programs/${encodeURIComponent(name)}`);
      this.dialog = null;
      this.dirty = false;
      await this.listPrograms();
      if (this.programs.length > 0) await this.open(this.programs[0].name);
      else this.startNew();
    } catch (err) {
      this.dialogError = errorText(err);
    } finally {
      this.busy = false;
    }
  }

  // --- editing ----------------------------------------------------------------------------

  private async loadModel(robot: string): Promise<boolean> {
    try {
      const model = await api<RobotModel>("GET", `/api/jog/robots/${encodeURIComponent(robot)}`);
      if (robot === focus.robot) this.model = model;
      return true;
    } catch {
      return false;
    }
  }

  private blocksChanged(): void {
    if (!this.editor) return;
    if (this.tab === "outline") this.requestUpdate();
    this.dirty = JSON.stringify(this.editor.state()) !== this.saved;
    window.clearTimeout(this.previewTimer);
    this.previewTimer = window.setTimeout(() => void this.preview(), PREVIEW_DELAY_MS);
  }

  private historyChanged(): void {
    if (!this.editor) return;
    this.history = { undo: this.editor.canUndo(), redo: this.editor.canRedo() };
  }

  /** The Python of the blocks as they are now, or why there is none. */
  private async preview(): Promise<void> {
    if (!this.editor || this.source !== "blocks") return;
    const ticket = ++this.previewing;
    try {
      const generated = await api<Generated>("POST", "/api/programs/_generate", {
        workspace: this.editor.state(),
      });
      if (ticket !== this.previewing) return;
      this.python = generated.python;
      this.problem = "";
      this.showProblems(generated.problems);
    } catch (err) {
      if (ticket === this.previewing) this.problem = errorText(err);
    }
  }

  /** Warnings on the blocks, and the list under the run buttons; Run waits until none. */
  private showProblems(problems: Problem[]): void {
    this.problems = problems;
    this.editor?.warn(problems);
  }

  private breakpointsChanged(): void {
    this.requestUpdate();
    const status = this.status();
    if (this.editor && status && LIVE_STATES.includes(status.state)) {
      void api("PUT", `/api/programs/${encodeURIComponent(this.name)}/breakpoints`, {
        ids: this.editor.liveBreakpoints(),
      }).catch((err: unknown) => (this.notice = errorText(err)));
    }
  }

  // --- running ----------------------------------------------------------------------------

  private status(): RunStatus | undefined {
    return this.name ? runs.view(this.name)?.status : undefined;
  }

  private async fetchStatus(name: string): Promise<void> {
    const status = await api<RunStatus>(
      "GET",
      `/api/programs/${encodeURIComponent(name)}/status`,
    ).catch(() => null);
    if (status) runs.answer(status);
    this.showRun();
  }

  private async run(): Promise<void> {
    if (!this.editor) return;
    if (this.source === "blocks" && (this.dirty || !this.name) && !(await this.save())) return;
    const robot = focus.robot; // the robot blocks start with, until a "use robot" block
    const leases: Record<string, string> = {};
    for (const r of feed.robots()) {
      const token = control.token(r.local_name);
      if (token) leases[r.local_name] = token;
    }
    this.busy = true;
    try {
      const status = await api<RunStatus>("POST", `/api/programs/${encodeURIComponent(this.name)}/run`, {
        breakpoints: this.editor.liveBreakpoints(),
        leases,
        robot: robot || null,
      });
      this.notice = "";
      this.tab = "output";
      runs.answer(status);
    } catch (err) {
      this.notice = t("program.not_started", { error: errorText(err) });
    } finally {
      this.busy = false;
    }
  }

  private async command(action: "pause" | "resume" | "step" | "stop"): Promise<void> {
    if (action === "stop" && runs.sendStop(this.name)) return; // its outcome is pushed
    try {
      await api<RunStatus>("POST", `/api/programs/${encodeURIComponent(this.name)}/${action}`);
    } catch (err) {
      this.notice = errorText(err);
    }
  }

  /** The run's block highlighted on the workspace. */
  private showRun(): void {
    const status = this.status();
    const live = status !== undefined && LIVE_STATES.includes(status.state);
    const block = live ? status.block : null;
    if (block !== this.highlighted) {
      this.highlighted = block;
      this.editor?.highlight(block);
    }
    this.requestUpdate();
    if (status?.state === "error" && status.error?.block) this.editor?.reveal(status.error.block);
  }

  // --- view -------------------------------------------------------------------------------

  private renderProgramBar() {
    const blocks = this.source === "blocks";
    const live = LIVE_STATES.includes(this.status()?.state ?? "idle");
    return html`<div class="bar">
      <select
        data-testid="program-select"
        aria-label=${t("program.program")}
        @change=${(e: Event) => {
          const select = e.target as HTMLSelectElement;
          const wanted = select.value;
          select.value = this.name;
          void this.open(wanted);
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
      <button data-testid="new" @click=${async () => (await this.confirmDiscard()) && this.startNew()}>
        ${t("program.new")}
      </button>
      <button data-testid="save" class=${this.dirty || !this.name ? "primary" : ""}
        ?disabled=${!blocks || this.busy} @click=${() => this.save()}>${t("program.save")}</button>
      <button data-testid="rename" ?disabled=${!this.name || live}
        @click=${() => this.openDialog("rename")}>${t("program.rename")}</button>
      <button data-testid="duplicate" ?disabled=${!this.name}
        @click=${() => this.openDialog("duplicate")}>${t("program.duplicate")}</button>
      <button data-testid="delete" class="danger" ?disabled=${!this.name || live}
        @click=${() => this.openDialog("delete")}>${t("program.delete")}</button>
      <span class="spacer"></span>
      <button data-testid="undo" aria-label=${t("program.undo")} ?disabled=${!this.history.undo}
        @click=${() => this.editor?.undo(false)}>↶<span class="label"> ${t("program.undo")}</span>
      </button>
      <button data-testid="redo" aria-label=${t("program.redo")} ?disabled=${!this.history.redo}
        @click=${() => this.editor?.undo(true)}>↷<span class="label"> ${t("program.redo")}</span>
      </button>
    </div>`;
  }

  private renderRunControls() {
    const status = this.status();
    const state = status?.state ?? "idle";
    const live = LIVE_STATES.includes(state);
    const robot = focus.robot;
    const onBreakpoint = this.selected !== null && this.editor?.breakpoints.has(this.selected);
    return html`<div class="runpad">
        ${live
          ? html`<button class="stop wide" data-testid="stop" @click=${() => this.command("stop")}>
              ${t("program.stop")}
            </button>`
          : html`<button class="run wide" data-testid="run"
              ?disabled=${this.busy || this.loading || (this.source === "blocks"
                && (this.problem !== "" || this.problems.length > 0))}
              @click=${() => this.run()}>${t("program.run")}</button>`}
        ${state === "paused"
          ? html`<button data-testid="resume" @click=${() => this.command("resume")}>
              ${t("program.resume")}</button>`
          : html`<button data-testid="pause" ?disabled=${state !== "running"}
              @click=${() => this.command("pause")}>${t("program.pause")}</button>`}
        <button data-testid="step" ?disabled=${state !== "paused"}
          @click=${() => this.command("step")}>${t("program.step")}</button>
        <button data-testid="breakpoint" class="wide ${onBreakpoint ? "on" : ""}"
          ?disabled=${this.selected === null}
          @click=${() => this.selected && this.editor?.toggleBreakpoint(this.selected)}>
          ${onBreakpoint ? t("program.clear_breakpoint") : t("program.breakpoint_on_block")}
        </button>
      </div>
      <div class="status">
        <span class="chip ${stateClass(state)}" data-testid="run-state">${stateLabel(state)}</span>
        ${status?.block && live
          ? html`<span class="muted" data-testid="run-block" data-block=${status.block}>
              ${t("program.run_at", {
                block: this.editor?.describe(status.block) || status.block,
              })}</span>`
          : nothing}
        <span class="spacer"></span>
        <span class="muted" data-testid="run-robot">${robot
          ? t("program.runs_on", { robot }) : feed.robots().length ? t("program.tap_robot")
          : t("program.no_robot")}</span>
      </div>
      ${state === "paused" && status?.pause_reason === "confirm"
        ? html`<div class="confirm" role="alert" data-testid="confirm">
            <strong>${status.message || t("program.waits")}</strong>
            <button class="primary" @click=${() => this.command("resume")}>
              ${t("program.continue")}</button>
          </div>`
        : nothing}
      ${this.notice
        ? html`<p class="error" role="alert" data-testid="notice">${this.notice}</p>`
        : nothing}
      ${this.source === "blocks" && this.problems.length
        ? html`<div class="problems" data-testid="problems" role="alert">
            <strong>${this.problems.length === 1 ? t("program.fix_one")
              : t("program.fix_many", { count: this.problems.length })}</strong>
            ${this.problems.map((p) => html`<button class="problem" data-testid="problem-item"
              data-block=${p.block} @click=${() => this.editor?.reveal(p.block)}>
              ⚠ ${p.message}</button>`)}
          </div>`
        : nothing}`;
  }

  private renderOutput() {
    const view = this.name ? runs.view(this.name) : undefined;
    const status = view?.status;
    const lines: (OutputEntry | null)[] = view?.output ?? [];
    return html`<div class="pane" data-testid="output" role="log" aria-live="polite">
      ${lines.length === 0 && !status?.error
        ? html`<p class="muted">${t("program.output_empty")}</p>`
        : nothing}
      ${lines.map(
        (line) => line && html`<button class="line ${line.stream}" data-block=${line.block ?? ""}
          data-testid=${line.stream === "error" ? "run-error" : "output-line"}
          @click=${() => line.block && this.editor?.reveal(line.block)}>${line.text}</button>`,
      )}
      ${status?.error && !lines.some((line) => line?.stream === "error")
        ? html`<button class="line error" data-testid="run-error"
            @click=${() => status.error?.block && this.editor?.reveal(status.error.block)}
            >${status.error.line
              ? t("program.error_at_line", {
                  message: status.error.message,
                  line: status.error.line,
                })
              : status.error.message}</button>`
        : nothing}
      ${status && !status.error && status.message && !LIVE_STATES.includes(status.state)
        ? html`<p class="muted">${status.message}</p>`
        : nothing}
    </div>`;
  }

  /** The program as a tree, PolyScope-style: one line per statement; tap to go to it. */
  private renderOutline() {
    const items = this.editor?.outline() ?? [];
    const running = this.status()?.block ?? null;
    const flagged = new Set(this.problems.map((p) => p.block));
    return html`<div class="pane outline" data-testid="outline">
      ${items.length === 0 ? html`<p class="muted">${t("program.outline_empty")}</p>` : nothing}
      ${items.map((item) => html`<button class="item ${item.id === running ? "running" : ""}
          ${item.id === this.selected ? "chosen" : ""}" data-testid="outline-item"
          data-block=${item.id} style="padding-left:${10 + item.depth * 22}px"
          @click=${() => this.editor?.reveal(item.id)}>
          ${flagged.has(item.id) ? "⚠ " : ""}${item.text}</button>`)}
    </div>`;
  }

  /** The robot in focus, live, beside the blocks that move it. */
  private renderView() {
    const robot = focus.robot;
    const state = feed.states.get(robot);
    return html`<div class="pane view" data-testid="program-view">
      ${robot
        ? html`<op-robot-view .model=${this.model}
            .joints=${this.model?.name === robot ? state?.joint_position ?? null : null}
          ></op-robot-view>`
        : html`<p class="muted">${t("program.view_no_robot")}</p>`}
    </div>`;
  }

  private renderPython() {
    return html`<div class="pane" data-testid="python">
      ${this.problem
        ? html`<p class="error" role="alert" data-testid="problem">${this.problem}</p>`
        : nothing}
      <pre class="code">${readable(this.python) || t("program.python_empty")}</pre>
    </div>`;
  }

  private renderDialog() {
    const close = () => (this.dialog = null);
    if (this.dialog === "delete") {
      return html`<op-modal heading=${t("program.delete_heading", { name: this.name })}
        @close=${close}>
        <p>${t("program.delete_text")}</p>
        ${this.dialogError ? html`<p class="error" role="alert">${this.dialogError}</p>` : nothing}
        <div class="actions">
          <button @click=${close}>${t("program.cancel")}</button>
          <button class="danger" data-testid="delete-confirm" ?disabled=${this.busy}
            @click=${() => this.deleteProgram()}>${t("program.delete")}</button>
        </div>
      </op-modal>`;
    }
    const heading = {
      new: t("program.save_new_heading"),
      rename: t("program.rename_heading", { name: this.name }),
      duplicate: t("program.duplicate_heading", { name: this.name }),
    }[this.dialog ?? "new"];
    return html`<op-name-dialog
      heading=${heading}
      value=${this.dialog === "duplicate" ? `${this.name}_copy` : this.name}
      confirmLabel=${this.dialog === "duplicate" ? t("program.duplicate") : t("program.save")}
      error=${this.dialogError}
      ?busy=${this.busy}
      @confirm=${(e: CustomEvent<{ name: string }>) => this.nameChosen(e.detail.name)}
      @close=${close}
    ></op-name-dialog>`;
  }

  private openDialog(dialog: Exclude<Dialog, null>): void {
    this.dialogError = "";
    this.dialog = dialog;
  }

  render() {
    return html`
      ${this.renderProgramBar()}
      <div class="work">
        <div class="blockly">
          <div class="host" data-testid="workspace"></div>
          ${this.loading
            ? html`<div class="cover" role="progressbar" aria-label=${t("program.loading_editor")}>
                ${t("program.loading_block_editor")}</div>`
            : nothing}
          ${!this.loading && this.source === "python"
            ? html`<div class="cover">
                <p>${t("program.python_only", { name: this.name })}</p>
              </div>`
            : nothing}
        </div>
        <div class="side">
          ${this.renderRunControls()}
          <div class="tabs" role="tablist">
            ${TABS.map(([tab, label]) => html`<button role="tab" data-testid="tab-${tab}"
              aria-selected=${this.tab === tab} @click=${() => (this.tab = tab)}>
              ${t(label)}${tab === "python" && this.problem ? " ⚠" : ""}</button>`)}
          </div>
          ${this.tab === "output" ? this.renderOutput()
            : this.tab === "outline" ? this.renderOutline()
            : this.tab === "view" ? this.renderView()
            : this.renderPython()}
        </div>
      </div>
      ${this.dialog ? this.renderDialog() : nothing}
    `;
  }
}

type Tab = "output" | "outline" | "python" | "view";
const TABS: [Tab, StringKey][] = [
  ["output", "program.tab.output"],
  ["outline", "program.tab.outline"],
  ["python", "program.tab.python"],
  ["view", "program.tab.view"],
];

const STATE_LABEL: Record<RunState, StringKey> = {
  idle: "program.state.idle",
  starting: "program.state.starting",
  running: "program.state.running",
  paused: "program.state.paused",
  stopped: "program.state.stopped",
  error: "program.state.error",
  finished: "program.state.finished",
};

/** A run state as people read it; a state this UI does not know shows as the server says. */
function stateLabel(state: string): string {
  return Object.hasOwn(STATE_LABEL, state) ? t(STATE_LABEL[state as RunState]) : state;
}

function stateClass(state: string): string {
  if (state === "running" || state === "finished") return "ok";
  if (state === "paused" || state === "starting") return "warn";
  if (state === "error") return "bad";
  return "";
}

customElements.define("op-program-panel", OpProgramPanel);
