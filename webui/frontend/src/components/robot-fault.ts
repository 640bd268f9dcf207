import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { shared } from "../styles";
import type { AddedDevice, RobotState } from "../types";

export type FaultKind = "link" | "controller" | "estop" | "protective_stop" | "error";

const TITLE = {
  link: "fault.link.title",
  controller: "fault.controller.title",
  estop: "fault.estop.title",
  protective_stop: "fault.protective_stop.title",
  error: "fault.error.title",
} as const;

const WHAT_TO_DO = {
  link: "fault.link.todo",
  controller: "fault.controller.todo",
  estop: "fault.estop.todo",
  protective_stop: "fault.protective_stop.todo",
  error: "fault.error.todo",
} as const;

/** What stops the robot, worst first, or null when nothing does. */
export function faultOf(device: AddedDevice | undefined, state: RobotState | undefined):
    FaultKind | null {
  if (!device) return null;
  if (device.status !== "connected") return "link";
  if (!state) return null; // linked, its first state on its way: nothing to say yet
  const flags = state.flags;
  if (flags.estop) return "estop";
  if (flags.protective_stop) return "protective_stop";
  if (flags.communication_failure) return "controller";
  if (flags.error) return "error";
  return null;
}

// Why the robot in focus cannot move and what to do about it, in words a technician acts
// on: the link lost, the E-stop, a protective stop, the driver without its controller, a
// fault. The driver's own message (what the controller said) is shown with it. Also says
// when the controller runs on its reduced safety limits (not a fault: the arm still moves).
export class OpRobotFault extends LitElement {
  static properties = {
    robot: { type: String },
    device: { attribute: false },
    state: { attribute: false },
    unlocks: { type: Boolean },
  };
  declare robot: string;
  declare device: AddedDevice | undefined;
  declare state: RobotState | undefined;
  declare unlocks: boolean; // its Reset error unlocks a protective stop (a UR)

  static styles = [
    shared,
    css`
      :host {
        display: block;
      }
      .fault {
        border: 2px solid var(--bad);
        background: var(--bad-bg);
        border-radius: 12px;
        padding: 10px 14px;
        margin-bottom: 12px;
      }
      .fault strong {
        color: var(--bad-fg);
        font-size: 18px;
      }
      .fault p {
        margin: 6px 0 0;
      }
      .detail {
        font-family: ui-monospace, monospace;
        font-size: 14px;
        overflow-wrap: anywhere;
      }
      .reduced {
        margin-bottom: 12px;
      }
    `,
  ];

  constructor() {
    super();
    this.robot = "";
    this.device = undefined;
    this.state = undefined;
    this.unlocks = false;
  }

  private detail(kind: FaultKind): string {
    if (kind === "link") return this.device?.last_error ?? "";
    return this.state?.error_message ?? "";
  }

  render() {
    const kind = faultOf(this.device, this.state);
    const reduced = kind === null && !!this.state?.flags.reduced_speed;
    if (kind === null) {
      return reduced
        ? html`<div class="chip warn reduced" data-testid="robot-reduced">
            ${t("fault.reduced")}</div>`
        : html``;
    }
    const detail = this.detail(kind);
    return html`<div class="fault" role="alert" data-testid="robot-fault" data-kind=${kind}>
      <strong>${t(TITLE[kind], { robot: this.robot })}</strong>
      <p>${t(kind === "protective_stop" && this.unlocks
        ? "fault.protective_stop.todo_unlock" : WHAT_TO_DO[kind])}</p>
      ${detail ? html`<p class="detail" data-testid="robot-fault-detail">${detail}</p>` : ""}
    </div>`;
  }
}

customElements.define("op-robot-fault", OpRobotFault);
