import { LitElement, css, html } from "lit";
import { api, ApiError, errorText } from "../api";
import { control } from "../control";
import { FocusController, focus } from "../focus";
import { t } from "../i18n";
import { JogSocket, type JogMessage, type JogStatus } from "../jog-socket";
import { FeedController, feed } from "../live";
import { conjugate, multiply, quaternionToRpy, rotate } from "../math";
import { RobotLoader } from "../robot-loader";
import { shared } from "../styles";
import type { Marker } from "../three/scene";
import type { Pose, RobotState } from "../types";
import {
  angle,
  angleText,
  angleUnit,
  angleWithUnit,
  length,
  lengthUnit,
  lengthWithUnit,
  radians,
  roughLength,
} from "../units";
import "../components/clearance-chip";
import "../components/jog-pad";
import "../components/mouse-card";
import "../components/name-dialog";
import "../components/robot-view";
import "../components/waypoint-list";
import type { JogAxis } from "../components/jog-pad";
import type { RobotModel } from "../components/robot-view";
import type { MoveProgress, Waypoint } from "../components/waypoint-list";

type Mode = "joint" | "base" | "tool";
type Stepping = "continuous" | "fine" | "coarse";
const CARTESIAN = ["x", "y", "z", "rx", "ry", "rz"];
const RAD = Math.PI / 180;
// Incremental steps: fine = 0.1 mm / 0.1°, coarse = 1 mm / 1°.
const STEP = { fine: { linear: 0.0001, angular: 0.1 * RAD }, coarse: { linear: 0.001, angular: RAD } };
const MODE_LABEL = { joint: "jog.joints", base: "jog.base", tool: "jog.tool" } as const;

/** A step size in the chosen units to two significant digits: "1 mm", "0.1°", "0.039 in". */
function stepLabel(size: { linear: number; angular: number }): string {
  const short = (text: string): string => String(Number(Number(text).toPrecision(2)));
  const turn = short(angle(size.angular, 6));
  return t("jog.step", {
    length: `${short(length(size.linear, 6))} ${lengthUnit()}`,
    angle: angleText(turn),
  });
}

type Dialog =
  | { kind: "teach"; type: "joint" | "pose"; frame: "base" | "world"; name: string;
      error: string; overwrite: boolean }
  | { kind: "rename"; from: string; name: string; tags: string[]; error: string }
  | { kind: "delete"; name: string }
  | null;

// Jogging and teaching: hold-to-run buttons, the live 3D view, waypoints, the 3D mouse.
export class OpJogPanel extends LitElement {
  static properties = {
    robot: { state: true },
    model: { state: true },
    mode: { state: true },
    stepping: { state: true },
    status: { state: true },
    message: { state: true },
    waypoints: { state: true },
    selected: { state: true },
    dialog: { state: true },
    mouse: { state: true },
    mouseOn: { state: true },
    sensitivity: { state: true },
  };
  declare robot: string;
  declare model: RobotModel | null;
  declare mode: Mode;
  declare stepping: Stepping;
  declare status: JogStatus | null;
  declare message: string;
  declare waypoints: Waypoint[];
  declare selected: string;
  declare dialog: Dialog;
  declare mouse: string;
  declare mouseOn: boolean;
  declare sensitivity: number;
  private socket = new JogSocket();
  private press = "";
  private movingTo = ""; // the waypoint a held Move to is going to
  private toolZero: Pose | null = null; // the TCP when Tool was chosen: tool readings count from it
  private boundMouse = "";
  private loadError = "";
  private onVisibility = () => document.hidden && this.socket.releaseAll();
  private onBlur = () => this.socket.releaseAll();
  private onControl = () => this.requestUpdate();
  private onStop = () => this.socket.releaseAll();

  static styles = [
    shared,
    css`
      .top {
        display: flex;
        gap: 10px;
        flex-wrap: wrap;
        align-items: center;
        margin-bottom: 12px;
      }
      .top .spacer {
        flex: 1;
      }
      .layout {
        display: grid;
        grid-template-columns: minmax(0, 1fr) minmax(0, 1fr);
        grid-template-areas: "view controls" "waypoints controls";
        grid-template-rows: auto 1fr;
        gap: 14px;
      }
      .view {
        grid-area: view;
      }
      .controls {
        grid-area: controls;
      }
      .waypoints {
        grid-area: waypoints;
        align-self: start;
      }
      @media (max-width: 1000px) {
        .layout {
          grid-template-columns: minmax(0, 1fr);
          grid-template-areas: "view" "controls" "waypoints";
        }
      }
      op-robot-view {
        height: 380px;
      }
      @media (max-width: 700px) {
        op-robot-view {
          height: 260px;
        }
      }
      .readout {
        display: grid;
        grid-template-columns: repeat(3, 1fr);
        gap: 6px;
        margin-top: 10px;
        font-variant-numeric: tabular-nums;
      }
      .readout div {
        background: var(--panel);
        border-radius: 8px;
        padding: 6px 10px;
      }
      .readout small {
        display: block;
        color: var(--muted);
        font-size: 13px;
      }
      .segmented {
        display: flex;
        gap: 6px;
        flex-wrap: wrap;
        margin-bottom: 10px;
      }
      .segmented button[aria-pressed="true"] {
        border-color: var(--accent);
        color: var(--accent);
      }
      .deadman {
        display: block;
        white-space: normal; /* a long halt reason wraps, never runs off the screen */
        overflow-wrap: anywhere;
        padding: 10px 14px;
        border-radius: 10px;
        margin-bottom: 10px;
        font-weight: 600;
      }
      section.card {
        margin-bottom: 14px;
      }
      select {
        min-height: 56px;
        font: inherit;
        background: var(--bg);
        color: var(--text);
        border: 2px solid var(--line);
        border-radius: 10px;
        padding: 0 12px;
      }
      .row {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
        align-items: center;
      }
    `,
  ];

  constructor() {
    super();
    new FeedController(this);
    new FocusController(this);
    new RobotLoader(this, (robot) => this.loadRobot(robot));
    this.robot = "";
    this.model = null;
    this.mode = "joint";
    this.stepping = "continuous";
    this.status = null;
    this.message = "";
    this.waypoints = [];
    this.selected = "";
    this.dialog = null;
    this.mouse = "";
    this.mouseOn = false;
    this.sensitivity = Number(localStorage.getItem("op.mouseSensitivity") ?? "100") || 100;
    this.socket.addEventListener("message", (e) => this.onMessage((e as CustomEvent<JogMessage>).detail));
    this.socket.addEventListener("change", () => {
      if (!this.socket.online) this.status = null; // what was held ended with the link
      this.requestUpdate();
    });
  }

  async connectedCallback(): Promise<void> {
    super.connectedCallback();
    this.socket.connect();
    document.addEventListener("visibilitychange", this.onVisibility);
    window.addEventListener("blur", this.onBlur);
    control.addEventListener("change", this.onControl);
    window.addEventListener("op-stop", this.onStop);
    try {
      const settings = await api<{ heartbeat_ms: number }>("GET", "/api/jog/settings");
      this.socket.heartbeatMs = settings.heartbeat_ms;
    } catch {
      // keep the default heartbeat period
    }
  }

  disconnectedCallback(): void {
    this.socket.releaseAll();
    this.socket.close(); // the server halts anything this page was moving
    document.removeEventListener("visibilitychange", this.onVisibility);
    window.removeEventListener("blur", this.onBlur);
    control.removeEventListener("change", this.onControl);
    window.removeEventListener("op-stop", this.onStop);
    super.disconnectedCallback();
  }

  // Robot selection and its model --------------------------------------------------------------

  protected willUpdate(): void {
    const robot = focus.robot;
    if (robot !== this.robot) {
      this.socket.releaseAll(); // nothing held on one robot carries over to another
      if (this.mouseOn) this.setMouse(false);
      this.toolZero = null;
      this.robot = robot;
    }
  }

  protected updated(changed: Map<string, unknown>): void {
    if (changed.has("robot") && this.robot) control.resume(this.robot);
    // The mouse follows the frame buttons, the speed override and its sensitivity at once.
    if (this.mouseOn && this.mouseBinding() !== this.boundMouse) this.setMouse(true);
  }

  private async loadRobot(robot: string): Promise<boolean> {
    if (this.model?.name !== robot) this.model = null;
    try {
      const model = await api<RobotModel>("GET", `/api/jog/robots/${encodeURIComponent(robot)}`);
      if (robot !== this.robot) return true; // the focus moved on meanwhile
      this.model = model;
      if (this.message === this.loadError) this.message = "";
      this.loadError = "";
      return await this.loadWaypoints();
    } catch (err) {
      this.loadError = this.message = errorText(err);
      return false;
    }
  }

  private async loadWaypoints(): Promise<boolean> {
    try {
      this.waypoints = await api<Waypoint[]>(
        "GET",
        `/api/jog/robots/${encodeURIComponent(this.robot)}/waypoints`,
      );
      return true;
    } catch (err) {
      this.message = errorText(err);
      return false;
    }
  }

  // Control and power ----------------------------------------------------------------------

  private async toggleControl(): Promise<void> {
    this.message = "";
    try {
      if (control.holds(this.robot)) await control.release(this.robot);
      else await control.take(this.robot);
    } catch (err) {
      this.message = errorText(err);
    }
  }

  private async power(command: "enable" | "disable" | "reset_errors"): Promise<void> {
    this.message = "";
    try {
      await api("POST", `/api/jog/robots/${encodeURIComponent(this.robot)}/${command}`, undefined, {
        "X-Lease-Token": control.token(this.robot) ?? "",
      });
    } catch (err) {
      if (err instanceof ApiError && err.code === "lease_held") control.forget(this.robot);
      this.message = errorText(err);
    }
  }

  // Jogging --------------------------------------------------------------------------------

  private base(): Record<string, unknown> {
    return { robot: this.robot, token: control.token(this.robot), speed: focus.speed / 100 };
  }

  private hold(axis: string, direction: number): void {
    this.message = "";
    if (!control.holds(this.robot)) {
      this.message = t("jog.control.take_first");
      return;
    }
    const joint = this.mode === "joint";
    const linear = !joint && ["x", "y", "z"].includes(axis);
    let step: number | undefined;
    if (this.stepping !== "continuous") {
      const size = STEP[this.stepping];
      step = joint ? size.angular : linear ? size.linear : size.angular;
    }
    this.press = this.socket.press(
      {
        type: "jog",
        ...this.base(),
        kind: joint ? "joint" : "cartesian",
        axis: joint ? Number(axis) : axis,
        direction,
        frame: this.mode === "tool" ? "tool" : "base",
        ...(step === undefined ? {} : { step }),
      },
      step === undefined,
    );
  }

  private release(): void {
    if (this.press) this.socket.release(this.press);
    this.press = "";
    this.movingTo = "";
  }

  private holdWaypoint(name: string): void {
    this.message = "";
    if (!control.holds(this.robot)) {
      this.message = t("jog.control.take_first");
      return;
    }
    this.selected = name;
    this.movingTo = name;
    this.press = this.socket.press({ type: "move_to", ...this.base(), waypoint: name });
  }

  private onMessage(message: JogMessage): void {
    if (message.type === "status") {
      this.status = message;
      if (message.press === this.press && !["moving", "held"].includes(message.state)) {
        this.movingTo = "";
      }
      if (message.state === "refused" && message.reason === "lease_held") control.forget(this.robot);
      if (message.press.startsWith("mouse:") && !["moving", "held"].includes(message.state)) {
        this.mouseOn = false;
        this.boundMouse = "";
      }
    } else if (message.type === "taught") {
      this.message = t("jog.saved_by_mouse", { name: message.name });
      void this.loadWaypoints();
    } else if (message.type === "mouse_frame") {
      this.mode = message.mode === "joint" ? "joint" : message.frame === "tool" ? "tool" : "base";
      this.toolZero = null;
    } else if (message.type === "error") {
      this.message = message.error.message;
    }
  }

  // 3D mouse -------------------------------------------------------------------------------

  private mice() {
    return feed.devices.filter((d) => d.kind === "input" && d.status === "connected");
  }

  /** What the mouse should be bound with now, as sent. */
  private mouseBinding(): string {
    return JSON.stringify({
      type: "mouse",
      ...this.base(),
      speed: (focus.speed / 100) * (this.sensitivity / 100),
      device: this.mouse || this.mice()[0]?.local_name,
      mode: this.mode === "joint" ? "joint" : "cartesian",
      frame: this.mode === "tool" ? "tool" : "base",
      buttons: { "0": "teach", "1": "toggle_frame" },
    });
  }

  private setMouse(on: boolean): void {
    const device = this.mouse || this.mice()[0]?.local_name;
    if (!device) return;
    this.mouse = device;
    if (on && !control.holds(this.robot)) {
      this.message = t("jog.control.take_first");
      return;
    }
    this.mouseOn = on;
    const binding = this.mouseBinding();
    this.boundMouse = on ? binding : "";
    this.socket.send({ ...JSON.parse(binding), enabled: on });
  }

  private changeMouse(device: string): void {
    const on = this.mouseOn;
    if (on) this.setMouse(false); // the mouse that was on lets go first
    this.mouse = device;
    if (on) this.setMouse(true);
  }

  private setSensitivity(percent: number): void {
    this.sensitivity = percent;
    localStorage.setItem("op.mouseSensitivity", String(percent));
  }

  // Teaching -------------------------------------------------------------------------------

  private nextName(): string {
    const taken = new Set(this.waypoints.map((w) => w.name));
    for (let i = 1; ; i++) {
      const name = `wp_${String(i).padStart(3, "0")}`;
      if (!taken.has(name)) return name;
    }
  }

  /** One tap: saved at once under the next free name (rename it from the list). */
  private async quickTeach(type: "joint" | "pose", frame: "base" | "world"): Promise<void> {
    const name = this.nextName();
    try {
      await api("POST", `/api/jog/robots/${encodeURIComponent(this.robot)}/teach`, {
        name, kind: type, frame });
      this.selected = name;
      this.message = t("jog.saved", { name });
      await this.loadWaypoints();
    } catch (err) {
      this.message = errorText(err);
    }
  }

  private async teach(): Promise<void> {
    const d = this.dialog;
    if (d?.kind !== "teach") return;
    try {
      await api("POST", `/api/jog/robots/${encodeURIComponent(this.robot)}/teach`, {
        name: d.name,
        kind: d.type,
        frame: d.frame,
        overwrite: d.overwrite,
      });
      this.dialog = null;
      this.selected = d.name;
      this.message = t("jog.saved", { name: d.name });
      await this.loadWaypoints();
    } catch (err) {
      const exists = err instanceof ApiError && err.code === "exists";
      this.dialog = { ...d, overwrite: exists, error: exists
        ? t("jog.exists_overwrite", { name: d.name }) : errorText(err) };
    }
  }

  private async rename(): Promise<void> {
    const d = this.dialog;
    if (d?.kind !== "rename") return;
    try {
      if (d.name !== d.from) {
        await api("POST", `/api/variables/${encodeURIComponent(d.from)}/rename`, { to: d.name });
      }
      const path = `/api/variables/${encodeURIComponent(d.name)}`;
      const current = await api<{ type: string; value: unknown; tags: string[]; version: number }>(
        "GET", path);
      if (current.tags.join(",") !== d.tags.join(",")) {
        await api("PUT", path, { type: current.type, value: current.value, tags: d.tags,
          expected_version: current.version });
      }
      this.dialog = null;
      this.selected = d.name;
      await this.loadWaypoints();
    } catch (err) {
      this.dialog = { ...d, error: errorText(err) };
    }
  }

  private async deleteWaypoint(name: string): Promise<void> {
    try {
      await api("DELETE", `/api/variables/${encodeURIComponent(name)}`);
    } catch (err) {
      this.message = errorText(err);
    }
    this.dialog = null;
    await this.loadWaypoints();
  }

  private reteach(name: string): void {
    const waypoint = this.waypoints.find((w) => w.name === name);
    if (!waypoint) return;
    this.dialog = { kind: "teach", type: waypoint.type === "joint_waypoint" ? "joint" : "pose",
      frame: "base", name, error: t("jog.overwrite_confirm", { name }),
      overwrite: true };
  }

  // Rendering ------------------------------------------------------------------------------

  private axes(state: RobotState | undefined): JogAxis[] {
    if (this.mode === "joint") {
      const joints = this.model?.info.joints ?? [];
      return joints.map((_, i) => ({
        key: String(i),
        label: t("jog.joint_short", { number: i + 1 }),
        value: state ? angleWithUnit(state.joint_position[i]) : "–",
      }));
    }
    if (!state) return CARTESIAN.map((a) => ({ key: a, label: a.toUpperCase(), value: "–" }));
    let [x, y, z] = state.tcp_pose.position;
    let rpy = quaternionToRpy(state.tcp_pose.orientation);
    if (this.mode === "tool") {
      // Along the tool's own axes, counted from where the TCP was when Tool was chosen.
      this.toolZero ??= state.tcp_pose;
      const back = conjugate(this.toolZero.orientation);
      const p = this.toolZero.position;
      [x, y, z] = rotate(back, [0, 1, 2].map((i) => state.tcp_pose.position[i] - p[i]));
      rpy = quaternionToRpy(multiply(back, state.tcp_pose.orientation));
    }
    const values = [
      ...[x, y, z].map((v) => lengthWithUnit(v)),
      ...rpy.map((a) => angleWithUnit(radians(a))),
    ];
    return CARTESIAN.map((a, i) => ({ key: a, label: a.toUpperCase(), value: values[i] }));
  }

  /** How far the TCP still is from the waypoint a held Move to is going to. */
  private moveProgress(state: RobotState | undefined): MoveProgress | null {
    const target = this.waypoints.find((w) => w.name === this.movingTo);
    if (!target || !state) return null;
    const p = state.tcp_pose.position;
    const left = Math.hypot(...[0, 1, 2].map((i) => target.tcp_position[i] - p[i]));
    return { name: target.name, text: t("jog.moving_to_go", { distance: roughLength(left) }) };
  }

  private deadman() {
    const s = this.status;
    if (!this.socket.online) {
      return html`<div class="deadman chip bad" data-testid="deadman">${t("jog.link_down")}</div>`;
    }
    if (!s) {
      const ready = !control.holds(this.robot) ? t("jog.control.take_to_jog")
        : !feed.states.get(this.robot)?.flags.ready ? t("jog.enable_to_jog")
        : t("jog.ready");
      return html`<div class="deadman chip" data-testid="deadman">${ready}</div>`;
    }
    const cls = s.state === "moving" ? "ok" : s.state === "held" ? "warn"
      : s.state === "halted" || s.state === "refused" ? "bad" : "";
    const mouse = s.press.startsWith("mouse:") ? feed.inputState(s.press.slice(6)) : null;
    if (mouse && s.state === "moving") {
      const atRest = !mouse.axes.some((a) => a !== 0);
      return html`<div class="deadman chip ${atRest ? "" : "ok"}" data-testid="deadman">
        ${atRest ? t("jog.mouse.at_rest") : t("jog.mouse.moving")}</div>`;
    }
    const text = s.state === "moving" && this.movingTo
      ? t("jog.moving_to", { name: this.movingTo })
      : s.state === "moving" ? t("jog.moving")
      : s.state === "held" ? t("jog.not_moving", { reason: s.message ?? t("jog.held_back") })
      : s.state === "halted" ? t("jog.halted", { reason: s.reason ?? "" })
      : s.state === "refused" ? t("jog.refused", { reason: s.message ?? s.reason ?? "" })
      : s.state === "done" ? t("jog.arrived") : t("jog.stopped");
    return html`<div class="deadman chip ${cls}" data-testid="deadman">${text}</div>`;
  }

  private renderDialog() {
    const d = this.dialog;
    if (!d) return "";
    const close = () => (this.dialog = null);
    if (d.kind === "teach") {
      const heading = d.type === "joint" ? t("jog.dialog.save_joint")
        : d.frame === "base" ? t("jog.dialog.save_pose_base") : t("jog.dialog.save_pose_world");
      return html`<op-name-dialog heading=${heading}
        .value=${d.name} .error=${d.error}
        confirmLabel=${d.overwrite ? t("jog.dialog.overwrite") : t("jog.dialog.save")}
        @close=${close}
        @confirm=${(e: CustomEvent<{ name: string }>) => {
          this.dialog = { ...d, name: e.detail.name, overwrite: d.overwrite && e.detail.name === d.name };
          void this.teach();
        }}></op-name-dialog>`;
    }
    if (d.kind === "rename") {
      return html`<op-name-dialog heading=${t("jog.dialog.waypoint", { name: d.from })}
        .value=${d.name} tags=${d.tags.join(", ")} .error=${d.error}
        confirmLabel=${t("jog.dialog.save")} @close=${close}
        @confirm=${(e: CustomEvent<{ name: string; tags: string[] }>) => {
          this.dialog = { ...d, name: e.detail.name, tags: e.detail.tags };
          void this.rename();
        }}></op-name-dialog>`;
    }
    return html`<op-modal heading=${t("jog.dialog.delete", { name: d.name })} @close=${close}>
      <p>${t("jog.dialog.history_kept")}</p>
      <div class="row" style="justify-content:flex-end">
        <button @click=${close}>${t("jog.dialog.cancel")}</button>
        <button class="danger" data-testid="confirm-delete" @click=${() => this.deleteWaypoint(d.name)}>
          ${t("jog.dialog.confirm_delete")}</button>
      </div>
    </op-modal>`;
  }

  render() {
    const robots = feed.robots();
    if (!robots.length) {
      return html`<div class="card">
        <h2>${t("jog.no_robot")}</h2>
        <p>${t("jog.no_robot_hint")}</p>
        <button class="primary" @click=${() => (location.hash = "#/devices")}>
          ${t("jog.go_to_devices")}</button>
      </div>`;
    }
    if (!this.robot) {
      return html`<div class="card" data-testid="choose-robot">
        <h2>${t("jog.which_robot")}</h2>
        <p>${t("jog.which_robot_hint")}</p>
      </div>`;
    }
    const state = feed.states.get(this.robot);
    const device = robots.find((r) => r.local_name === this.robot);
    const mine = control.holds(this.robot);
    const controlledBy = device?.controlled_by;
    const canMove = mine && !!state?.flags.ready;
    const canPower = mine && !!state; // no state: the runtime or the robot's link is down
    const tcp = state ? state.tcp_pose.position.map((v) => length(v)) : ["–", "–", "–"];
    const rpy = state
      ? quaternionToRpy(state.tcp_pose.orientation).map((a) => angle(radians(a)))
      : ["–", "–", "–"];
    const markers: Marker[] = this.waypoints.map((w) => ({
      name: w.name, position: w.tcp_position, selected: w.name === this.selected }));
    const mice = this.mice();
    return html`
      <div class="top">
        <h2 style="margin:0" data-testid="jog-robot">${this.robot}</h2>
        <button data-testid="control" class=${mine ? "" : "primary"} @click=${this.toggleControl}>
          ${mine ? t("jog.control.release") : t("jog.control.take")}</button>
        <span class="chip ${mine ? "ok" : controlledBy ? "warn" : ""}" data-testid="lease">
          ${mine ? t("jog.control.yours", { holder: control.holder })
            : controlledBy ? t("jog.control.controlled_by", { holder: controlledBy })
            : t("jog.control.nobody")}</span>
        ${state?.flags.enabled
          ? html`<button data-testid="disable" ?disabled=${!canPower} @click=${() => this.power("disable")}>
              ${t("jog.disable")}</button>`
          : html`<button data-testid="enable" ?disabled=${!canPower} @click=${() => this.power("enable")}>
              ${t("jog.enable")}</button>`}
        ${state?.flags.error
          ? html`<button ?disabled=${!canPower} @click=${() => this.power("reset_errors")}>
              ${t("jog.reset_error")}</button>`
          : ""}
      </div>
      ${this.message ? html`<p class="error" role="alert" data-testid="jog-message">${this.message}</p>` : ""}
      <div class="layout">
        <div class="view">
          <op-robot-view .model=${this.model}
            .joints=${this.model?.name === this.robot ? state?.joint_position ?? null : null}
            .markers=${markers}></op-robot-view>
          <op-clearance-chip .robot=${this.robot}></op-clearance-chip>
          <div class="readout" data-testid="tcp-readout">
            <div><small>X ${lengthUnit()}</small>${tcp[0]}</div>
            <div><small>Y ${lengthUnit()}</small>${tcp[1]}</div>
            <div><small>Z ${lengthUnit()}</small>${tcp[2]}</div>
            <div><small>${t("jog.roll", { unit: angleUnit() })}</small>${rpy[0]}</div>
            <div><small>${t("jog.pitch", { unit: angleUnit() })}</small>${rpy[1]}</div>
            <div><small>${t("jog.yaw", { unit: angleUnit() })}</small>${rpy[2]}</div>
          </div>
        </div>
        <section class="card waypoints">
            <h2>${t("jog.waypoints")}</h2>
            <div class="row" style="margin-bottom:8px">
              <button data-testid="teach-joint" ?disabled=${!state}
                @click=${() => this.quickTeach("joint", "base")}>${t("jog.save_joints")}</button>
              <button data-testid="teach-pose" ?disabled=${!state}
                @click=${() => this.quickTeach("pose", "base")}>${t("jog.save_pose_base")}</button>
              <button ?disabled=${!state}
                @click=${() => this.quickTeach("pose", "world")}>
                ${t("jog.save_pose_world")}</button>
            </div>
            <op-waypoint-list .waypoints=${this.waypoints} ?disabled=${!canMove}
              .progress=${this.moveProgress(state)}
              selected=${this.selected}
              @waypoint-hold=${(e: CustomEvent) => this.holdWaypoint(e.detail.name)}
              @waypoint-release=${() => this.release()}
              @waypoint-rename=${(e: CustomEvent) => (this.dialog = { kind: "rename",
                from: e.detail.name, name: e.detail.name,
                tags: this.waypoints.find((w) => w.name === e.detail.name)?.tags ?? [],
                error: "" })}
              @waypoint-delete=${(e: CustomEvent) => (this.dialog = { kind: "delete",
                name: e.detail.name })}
              @waypoint-reteach=${(e: CustomEvent) => this.reteach(e.detail.name)}
            ></op-waypoint-list>
        </section>
        <div class="controls">
          ${this.deadman()}
          <div class="segmented" role="group" aria-label=${t("jog.frame")}>
            ${(["joint", "base", "tool"] as Mode[]).map((m) => html`<button
              data-testid="mode-${m}" aria-pressed=${this.mode === m ? "true" : "false"}
              @click=${() => {
                this.mode = m;
                this.toolZero = null; // Tool tapped (again): its readings count from here
              }}>${t(MODE_LABEL[m])}</button>`)}
          </div>
          <div class="segmented" role="group" aria-label=${t("jog.steps")}>
            ${(["continuous", "fine", "coarse"] as Stepping[]).map((s) => html`<button
              data-testid="step-${s}" aria-pressed=${this.stepping === s ? "true" : "false"}
              @click=${() => (this.stepping = s)}>${s === "continuous" ? t("jog.continuous")
                : stepLabel(STEP[s])}</button>`)}
          </div>
          <op-jog-pad .axes=${this.axes(state)} ?disabled=${!canMove}
            @jog-hold=${(e: CustomEvent) => this.hold(e.detail.axis, e.detail.direction)}
            @jog-release=${() => this.release()}></op-jog-pad>
          ${this.mode === "tool" ? html`<p class="muted" data-testid="tool-note">
              ${t("jog.tool_note")}</p>` : ""}
          ${!mine ? html`<p class="muted">${t("jog.control.take_to_jog_hint")}</p>`
            : !state?.flags.ready ? html`<p class="muted">${t("jog.enable_to_jog_hint")}</p>` : ""}
          <section class="card">
            <h2>${t("jog.mouse.title")}</h2>
            <op-mouse-card .mice=${mice} device=${this.mouse} ?on=${this.mouseOn}
              ?disabled=${!canMove} mode=${this.mode} sensitivity=${this.sensitivity}
              .input=${feed.inputState(this.mouse || mice[0]?.local_name || "")}
              @mouse-device=${(e: CustomEvent<string>) => this.changeMouse(e.detail)}
              @mouse-toggle=${(e: CustomEvent<boolean>) => this.setMouse(e.detail)}
              @mouse-sensitivity=${(e: CustomEvent<number>) => this.setSensitivity(e.detail)}
            ></op-mouse-card>
          </section>
        </div>
      </div>
      ${this.renderDialog()}
    `;
  }
}

customElements.define("op-jog-panel", OpJogPanel);
