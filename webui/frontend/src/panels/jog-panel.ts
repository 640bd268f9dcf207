import { LitElement, css, html } from "lit";
import { ApiError, client, errorText, ok } from "../api";
import { control } from "../control";
import { FocusController, focus } from "../focus";
import { t } from "../i18n";
import { worded } from "../i18n/words";
import type { JogMessage } from "../jog-socket";
import { Listening } from "../listening";
import { FeedController, feed } from "../live";
import { makes, request } from "../rights";
import { RobotLoader } from "../robot-loader";
import { shared } from "../styles";
import type { Marker } from "../three/scene";
import type { RobotState } from "../types";
import { roughLength } from "../units";
import { JogAxes, type Mode, type Stepping } from "../jog/axes";
import { Jogger } from "../jog/jogger";
import { Teaching, type WaypointDialog } from "../jog/teach";
import type { PowerCommand } from "../components/jog-header";
import type { RobotModel } from "../components/robot-view";
import type { MoveProgress, Waypoint } from "../components/waypoint-list";
import "../components/clearance-chip";
import "../components/gripper-card";
import "../components/hold-button";
import "../components/jog-header";
import "../components/jog-options";
import "../components/jog-pad";
import "../components/jog-status";
import "../components/jog-waypoints";
import "../components/mouse-card";
import "../components/robot-fault";
import "../components/robot-view";
import "../components/tcp-readout";

type Named = CustomEvent<{ name: string }>;

// Jogging and teaching: hold-to-run buttons, the live 3D view, waypoints, the 3D mouse.
// Holds and the mouse are in Jogger, teaching in Teaching; this lays them out.
export class OpJogPanel extends LitElement {
  static properties = {
    robot: { state: true },
    model: { state: true },
    mode: { state: true },
    stepping: { state: true },
    message: { state: true },
    waypoints: { state: true },
    selected: { state: true },
    dialog: { state: true },
  };
  declare robot: string;
  declare model: RobotModel | null;
  declare mode: Mode;
  declare stepping: Stepping;
  declare message: string;
  declare waypoints: Waypoint[];
  declare selected: string;
  declare dialog: WaypointDialog;
  private readonly jog = new Jogger(this, (message) => this.told(message));
  private readonly teaching = new Teaching(this);
  private readonly readings = new JogAxes();
  private loadError = "";
  private onControl = () => this.requestUpdate();

  static styles = [
    shared,
    css`
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
      section.card {
        margin-bottom: 14px;
      }
      op-hold-button.freedrive {
        display: block;
        margin: 12px 0 14px;
        --hold-font-size: 18px;
      }
    `,
  ];

  constructor() {
    super();
    new Listening(this, control, "change", this.onControl);
    new FeedController(this);
    new FocusController(this);
    new RobotLoader(this, (robot) => this.loadRobot(robot));
    this.robot = "";
    this.model = null;
    this.mode = "joint";
    this.stepping = "continuous";
    this.message = "";
    this.waypoints = [];
    this.selected = "";
    this.dialog = null;
  }

  // Robot selection and its model --------------------------------------------------------------

  protected willUpdate(): void {
    const robot = focus.robot;
    if (robot !== this.robot) {
      this.jog.leave(); // nothing held on one robot carries over to another
      this.readings.reset();
      this.robot = robot;
    }
  }

  protected updated(changed: Map<string, unknown>): void {
    if (changed.has("robot") && this.robot) control.resume(this.robot);
  }

  private async loadRobot(robot: string): Promise<boolean> {
    if (this.model?.name !== robot) this.model = null;
    try {
      const model = await ok(client.GET("/api/jog/robots/{robot}", { params: { path: { robot } } }));
      if (robot !== this.robot) return true; // the focus moved on meanwhile
      this.model = model;
      if (this.message === this.loadError) this.message = "";
      this.loadError = "";
      return await this.teaching.load();
    } catch (err) {
      this.loadError = this.message = errorText(err);
      return false;
    }
  }

  // Control, power, and what the jog service says ---------------------------------------------

  private async toggleControl(): Promise<void> {
    this.message = "";
    try {
      if (control.holds(this.robot)) await control.release(this.robot);
      else await control.take(this.robot);
    } catch (err) {
      this.message = errorText(err);
    }
  }

  private async power(command: PowerCommand): Promise<void> {
    this.message = "";
    try {
      await ok(client.POST(`/api/jog/robots/{robot}/${command}`, {
        params: { path: { robot: this.robot },
          header: { "X-Lease-Token": control.token(this.robot) ?? "" } },
      }));
    } catch (err) {
      if (err instanceof ApiError && err.code === "lease_held") control.forget(this.robot);
      this.message = errorText(err);
    }
  }

  private told(message: JogMessage): void {
    if (message.type === "taught") {
      this.message = t("jog.saved_by_mouse", { name: message.name });
      void this.teaching.load();
    } else if (message.type === "mouse_frame") {
      this.mode = message.mode === "joint" ? "joint" : message.frame === "tool" ? "tool" : "base";
      this.readings.reset();
    } else if (message.type === "error") {
      this.message = worded(message.error.message, message.error.words);
    }
  }

  // Rendering ------------------------------------------------------------------------------

  /** How far the TCP still is from the waypoint a held Move to is going to. */
  private moveProgress(state: RobotState | undefined): MoveProgress | null {
    const target = this.waypoints.find((w) => w.name === this.jog.movingTo);
    if (!target || !state) return null;
    const p = state.tcp_pose.position;
    const left = Math.hypot(...[0, 1, 2].map((i) => target.tcp_position[i] - p[i]));
    return { name: target.name, text: t("jog.moving_to_go", { distance: roughLength(left) }) };
  }

  private renderNoRobot() {
    if (!feed.robots().length) {
      return html`<div class="card">
        <h2>${t("jog.no_robot")}</h2>
        <p>${t("jog.no_robot_hint")}</p>
        <button class="primary" @click=${() => (location.hash = "#/devices")}>
          ${t("jog.go_to_devices")}</button>
      </div>`;
    }
    return html`<div class="card" data-testid="choose-robot">
      <h2>${t("jog.which_robot")}</h2>
      <p>${t("jog.which_robot_hint")}</p>
    </div>`;
  }

  render() {
    if (!this.robot || !feed.robots().length) return this.renderNoRobot();
    const jog = this.jog;
    const state = feed.states.get(this.robot);
    const device = feed.robots().find((r) => r.local_name === this.robot);
    const mine = control.holds(this.robot);
    const canMove = mine && !!state?.flags.ready;
    const why = canMove ? "" : t(mine ? "jog.enable_to_jog" : "jog.control.take_to_jog");
    const markers: Marker[] = this.waypoints.map((w) => ({
      name: w.name, position: w.tcp_position, selected: w.name === this.selected }));
    const mice = jog.mice();
    const press = jog.status?.press ?? "";
    return html`
      <op-jog-header robot=${this.robot} ?mine=${mine} holder=${mine ? control.holder : ""}
        controlledBy=${device?.controlled_by ?? ""} ?enabled=${!!state?.flags.enabled}
        ?error=${!!state?.flags.error} ?canPower=${mine && !!state}
        ?powersOn=${!!this.model?.info.capabilities.includes("power_on")}
        ?unlocks=${!!state?.flags.protective_stop
          && !!this.model?.info.capabilities.includes("unlock_protective_stop")}
        @control-toggle=${() => this.toggleControl()}
        @power=${(e: CustomEvent<{ command: PowerCommand }>) => this.power(e.detail.command)}
      ></op-jog-header>
      <op-robot-fault robot=${this.robot} .device=${device} .state=${state}
        ?unlocks=${!!this.model?.info.capabilities.includes("unlock_protective_stop")}
      ></op-robot-fault>
      ${this.message ? html`<p class="error" role="alert" data-testid="jog-message">${this.message}</p>` : ""}
      <div class="layout">
        <div class="view">
          <op-robot-view .model=${this.model}
            .joints=${this.model?.name === this.robot ? state?.joint_position ?? null : null}
            .markers=${markers}></op-robot-view>
          <op-clearance-chip .robot=${this.robot}></op-clearance-chip>
          <op-tcp-readout .pose=${state?.tcp_pose ?? null}></op-tcp-readout>
        </div>
        <op-jog-waypoints class="waypoints" robot=${this.robot} .waypoints=${this.waypoints}
          selected=${this.selected}
          ?canTeach=${!!state} ?canMove=${canMove} why=${why} .progress=${this.moveProgress(state)}
          .dialog=${this.dialog}
          @teach-now=${(e: CustomEvent<{ type: "joint" | "pose"; frame: "base" | "world" }>) =>
            this.teaching.quickTeach(e.detail.type, e.detail.frame)}
          @waypoint-hold=${(e: Named) => {
            if (jog.holdWaypoint(e.detail.name)) this.selected = e.detail.name;
          }}
          @waypoint-release=${() => jog.release()}
          @waypoint-rename=${(e: Named) => this.teaching.renaming(e.detail.name)}
          @waypoint-delete=${(e: Named) => (this.dialog = { kind: "delete", name: e.detail.name })}
          @waypoint-reteach=${(e: Named) => this.teaching.reteach(e.detail.name)}
          @dialog-confirm=${(e: CustomEvent<{ name: string; tags: string[] }>) =>
            this.teaching.confirm(e.detail.name, e.detail.tags)}
          @dialog-delete=${(e: Named) => this.teaching.remove(e.detail.name)}
          @dialog-close=${() => (this.dialog = null)}
        ></op-jog-waypoints>
        <div class="controls">
          <op-jog-status ?online=${jog.online} .status=${jog.status} ?mine=${mine}
            ?ready=${!!state?.flags.ready} movingTo=${jog.movingTo} ?freedrive=${jog.freedriving}
            .mouse=${press.startsWith("mouse:") ? feed.inputState(press.slice(6)) : null}
          ></op-jog-status>
          <op-jog-options mode=${this.mode} stepping=${this.stepping}
            @mode=${(e: CustomEvent<{ mode: Mode }>) => {
              this.mode = e.detail.mode;
              this.readings.reset(); // Tool tapped (again): its readings count from here
            }}
            @stepping=${(e: CustomEvent<{ stepping: Stepping }>) =>
              (this.stepping = e.detail.stepping)}
          ></op-jog-options>
          <op-jog-pad .axes=${this.readings.axes(this.mode, this.model?.info.joints.length ?? 0,
              state)} ?disabled=${!canMove} why=${why}
            @jog-hold=${(e: CustomEvent) => jog.hold(e.detail.axis, e.detail.direction)}
            @jog-release=${() => jog.release()}></op-jog-pad>
          ${this.model?.info.capabilities.includes("freedrive") ? html`
            <op-hold-button class="freedrive" data-testid="freedrive" ?disabled=${!canMove} why=${why}
              ${makes(request("WS", "/api/jog/ws"))}
              @hold-start=${() => jog.holdFreedrive()} @hold-end=${() => jog.release()}
              >${t("jog.freedrive")}</op-hold-button>` : ""}
          ${this.mode === "tool" ? html`<p class="muted" data-testid="tool-note">
              ${t("jog.tool_note")}</p>` : ""}
          ${!mine ? html`<p class="muted">${t("jog.control.take_to_jog_hint")}</p>`
            : !state?.flags.ready ? html`<p class="muted">${t("jog.enable_to_jog_hint")}</p>` : ""}
          <op-gripper-card></op-gripper-card>
          <section class="card">
            <h2>${t("jog.mouse.title")}</h2>
            <op-mouse-card .mice=${mice} device=${jog.mouse} ?on=${jog.mouseOn}
              ?disabled=${!canMove} mode=${this.mode} sensitivity=${jog.sensitivity}
              .input=${feed.inputState(jog.mouse || mice[0]?.local_name || "")}
              note=${jog.mouseNote()}
              @mouse-device=${(e: CustomEvent<string>) => jog.changeMouse(e.detail)}
              @mouse-toggle=${(e: CustomEvent<boolean>) => jog.setMouse(e.detail)}
              @mouse-sensitivity=${(e: CustomEvent<number>) => jog.setSensitivity(e.detail)}
            ></op-mouse-card>
          </section>
        </div>
      </div>
    `;
  }
}

customElements.define("op-jog-panel", OpJogPanel);
