import { LitElement, css, html, nothing } from "lit";
import { type StringKey, t } from "../i18n";
import { worded } from "../i18n/words";
import { shared } from "../styles";
import type { OutlineItem } from "../program/editor";
import { LIVE_STATES, type OutputEntry, type Problem, type RunStatus } from "../program/types";
import type { RobotModel } from "./robot-view";
import "./robot-view";

export type Tab = "output" | "outline" | "python" | "view";
const TABS: [Tab, StringKey][] = [
  ["output", "program.tab.output"],
  ["outline", "program.tab.outline"],
  ["python", "program.tab.python"],
  ["view", "program.tab.view"],
];

/** The Python as people read it: without the block markers the runtime runs it with. */
function readable(python: string): string {
  return python
    .split("\n")
    .filter((line) => !/^\s*at_block\(/.test(line))
    .join("\n");
}

// The Program panel's tabs beside the blocks: the run's output (tap a line to go to its
// block), the program as an outline, the generated Python, and the robot in focus in 3D.
// Emits tab {tab} and reveal {block}; the panel chooses the tab and goes to the block.
export class OpProgramSide extends LitElement {
  static properties = {
    tab: { type: String },
    status: { attribute: false },
    output: { attribute: false },
    outline: { attribute: false },
    selected: { attribute: false },
    problems: { attribute: false },
    problem: { type: String },
    python: { type: String },
    robot: { type: String },
    model: { attribute: false },
    joints: { attribute: false },
  };
  declare tab: Tab;
  declare status: RunStatus | null; // of the program shown
  declare output: (OutputEntry | null)[]; // of its run
  declare outline: OutlineItem[];
  declare selected: string | null; // the block selected
  declare problems: Problem[]; // blocks flagged in the outline
  declare problem: string; // why there is no Python
  declare python: string;
  declare robot: string; // in focus
  declare model: RobotModel | null;
  declare joints: number[] | null;

  static styles = [
    shared,
    css`
      :host {
        display: flex;
        flex-direction: column;
        gap: 8px;
        flex: 1;
        min-height: 0;
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
      @media (max-width: 700px) {
        .pane {
          max-height: 40vh;
        }
      }
    `,
  ];

  constructor() {
    super();
    this.tab = "output";
    this.status = null;
    this.output = [];
    this.outline = [];
    this.selected = null;
    this.problems = [];
    this.problem = "";
    this.python = "";
    this.robot = "";
    this.model = null;
    this.joints = null;
  }

  private reveal(block: string | null | undefined): void {
    if (block) this.dispatchEvent(new CustomEvent("reveal", { detail: { block } }));
  }

  private renderOutput() {
    const status = this.status;
    const lines = this.output;
    return html`<div class="pane" data-testid="output" role="log" aria-live="polite">
      ${lines.length === 0 && !status?.error
        ? html`<p class="muted">${t("program.output_empty")}</p>`
        : nothing}
      ${lines.map(
        (line) => line && html`<button class="line ${line.stream}" data-block=${line.block ?? ""}
          data-testid=${line.stream === "error" ? "run-error" : "output-line"}
          @click=${() => this.reveal(line.block)}>${worded(line.text, line.words)}</button>`,
      )}
      ${status?.error && !lines.some((line) => line?.stream === "error")
        ? html`<button class="line error" data-testid="run-error"
            @click=${() => this.reveal(status.error?.block)}
            >${status.error.line
              ? t("program.error_at_line", {
                  message: worded(status.error.message, status.error.words),
                  line: status.error.line,
                })
              : worded(status.error.message, status.error.words)}</button>`
        : nothing}
      ${status && !status.error && status.message && !LIVE_STATES.includes(status.state)
        ? html`<p class="muted">${status.message}</p>`
        : nothing}
    </div>`;
  }

  /** The program as a tree, PolyScope-style: one line per statement; tap to go to it. */
  private renderOutline() {
    const items = this.outline;
    const running = this.status?.block ?? null;
    const flagged = new Set(this.problems.map((p) => p.block));
    return html`<div class="pane outline" data-testid="outline">
      ${items.length === 0 ? html`<p class="muted">${t("program.outline_empty")}</p>` : nothing}
      ${items.map((item) => html`<button class="item ${item.id === running ? "running" : ""}
          ${item.id === this.selected ? "chosen" : ""}" data-testid="outline-item"
          data-block=${item.id} style="padding-left:${10 + item.depth * 22}px"
          @click=${() => this.reveal(item.id)}>
          ${flagged.has(item.id) ? "⚠ " : ""}${item.text}</button>`)}
    </div>`;
  }

  /** The robot in focus, live, beside the blocks that move it. */
  private renderView() {
    return html`<div class="pane view" data-testid="program-view">
      ${this.robot
        ? html`<op-robot-view .model=${this.model} .joints=${this.joints}></op-robot-view>`
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

  render() {
    return html`<div class="tabs" role="tablist">
        ${TABS.map(([tab, label]) => html`<button role="tab" data-testid="tab-${tab}"
          aria-selected=${this.tab === tab}
          @click=${() => this.dispatchEvent(new CustomEvent("tab", { detail: { tab } }))}>
          ${t(label)}${tab === "python" && this.problem ? " ⚠" : ""}</button>`)}
      </div>
      ${this.tab === "output" ? this.renderOutput()
        : this.tab === "outline" ? this.renderOutline()
        : this.tab === "view" ? this.renderView()
        : this.renderPython()}`;
  }
}

customElements.define("op-program-side", OpProgramSide);
