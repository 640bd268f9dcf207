import { LitElement, css, html, nothing } from "lit";
import { type StringKey, t } from "../i18n";
import { worded } from "../i18n/words";
import { makes, request } from "../rights";
import { shared } from "../styles";
import type { RunCommand } from "../program/runner";
import { LIVE_STATES, type Problem, type RunState, type RunStatus } from "../program/types";

// The head of the Program panel's side column: run or stop, pause or resume, step, a
// breakpoint on the block selected; the run's state, the block it is at and the robot it
// runs on; a confirmation the program waits for; what went wrong; and what keeps the blocks
// from running (tap one to go to its block). Emits run, run-command {action},
// breakpoint-toggle and reveal {block}; the panel acts.
export class OpRunControls extends LitElement {
  static properties = {
    program: { type: String },
    status: { attribute: false },
    runnable: { type: Boolean },
    selected: { attribute: false },
    breakpoint: { type: Boolean },
    block: { type: String },
    robot: { type: String },
    robots: { type: Boolean },
    notice: { type: String },
    problems: { attribute: false },
  };
  declare program: string; // the program shown ("" before its first save)
  declare status: RunStatus | null; // of the program shown, null: never run
  declare runnable: boolean; // Run is enabled
  declare selected: string | null; // the block selected, if a breakpoint can go on it
  declare breakpoint: boolean; // the block selected has one
  declare block: string; // the block the run is at, as text
  declare robot: string; // the robot in focus
  declare robots: boolean; // any robot added at all
  declare notice: string;
  declare problems: Problem[];

  static styles = [
    shared,
    css`
      :host {
        display: flex;
        flex-direction: column;
        gap: 8px;
      }
      .runpad {
        display: grid;
        grid-template-columns: 1fr 1fr;
        gap: 8px;
      }
      .runpad .wide {
        grid-column: span 2;
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
      .spacer {
        flex: 1;
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
    `,
  ];

  constructor() {
    super();
    this.program = "";
    this.status = null;
    this.runnable = false;
    this.selected = null;
    this.breakpoint = false;
    this.block = "";
    this.robot = "";
    this.robots = false;
    this.notice = "";
    this.problems = [];
  }

  private emit(type: string, detail?: object): void {
    this.dispatchEvent(new CustomEvent(type, { detail }));
  }

  private command(action: RunCommand): void {
    this.emit("run-command", { action });
  }

  // Run saves a new program first, under a name asked then: its path is any program's.
  private path(): string {
    return `/api/programs/${encodeURIComponent(this.program || "new")}`;
  }

  private commands(action: RunCommand) {
    return makes(request("POST", `${this.path()}/${action}`));
  }

  render() {
    const status = this.status;
    const state = status?.state ?? "idle";
    const live = LIVE_STATES.includes(state);
    const robot = this.robot;
    return html`<div class="runpad">
        ${live
          ? html`<button class="stop wide" data-testid="stop" @click=${() => this.command("stop")}
              ${this.commands("stop")}>
              ${t("program.stop")}
            </button>`
          : html`<button class="run wide" data-testid="run" ?disabled=${!this.runnable}
              ${makes(request("POST", `${this.path()}/run`))}
              @click=${() => this.emit("run")}>${t("program.run")}</button>`}
        ${state === "paused"
          ? html`<button data-testid="resume" @click=${() => this.command("resume")}
              ${this.commands("resume")}>
              ${t("program.resume")}</button>`
          : html`<button data-testid="pause" ?disabled=${state !== "running"}
              ${this.commands("pause")}
              @click=${() => this.command("pause")}>${t("program.pause")}</button>`}
        <button data-testid="step" ?disabled=${state !== "paused"} ${this.commands("step")}
          @click=${() => this.command("step")}>${t("program.step")}</button>
        <button data-testid="breakpoint" class="wide ${this.breakpoint ? "on" : ""}"
          ?disabled=${this.selected === null}
          ${makes(request("PUT", `${this.path()}/breakpoints`))}
          @click=${() => this.selected && this.emit("breakpoint-toggle")}>
          ${this.breakpoint ? t("program.clear_breakpoint") : t("program.breakpoint_on_block")}
        </button>
      </div>
      <div class="status">
        <span class="chip ${stateClass(state)}" data-testid="run-state">${stateLabel(state)}</span>
        ${status?.block && live
          ? html`<span class="muted" data-testid="run-block" data-block=${status.block}>
              ${t("program.run_at", { block: this.block || status.block })}</span>`
          : nothing}
        <span class="spacer"></span>
        <span class="muted" data-testid="run-robot">${robot
          ? t("program.runs_on", { robot }) : this.robots ? t("program.tap_robot")
          : t("program.no_robot")}</span>
      </div>
      ${state === "paused" && status?.pause_reason === "confirm"
        ? html`<div class="confirm" role="alert" data-testid="confirm">
            <strong>${status.message || t("program.waits")}</strong>
            <button class="primary" data-testid="continue" @click=${() => this.command("resume")}
              ${this.commands("resume")}>
              ${t("program.continue")}</button>
          </div>`
        : nothing}
      ${this.notice
        ? html`<p class="error" role="alert" data-testid="notice">${this.notice}</p>`
        : nothing}
      ${this.problems.length
        ? html`<div class="problems" data-testid="problems" role="alert">
            <strong>${this.problems.length === 1 ? t("program.fix_one")
              : t("program.fix_many", { count: this.problems.length })}</strong>
            ${this.problems.map((p) => html`<button class="problem" data-testid="problem-item"
              data-block=${p.block} @click=${() => this.emit("reveal", { block: p.block })}>
              ⚠ ${worded(p.message, p.words)}</button>`)}
          </div>`
        : nothing}`;
  }
}

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

customElements.define("op-run-controls", OpRunControls);
