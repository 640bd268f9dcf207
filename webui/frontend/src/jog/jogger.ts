// Hold-to-run on the Jog panel: the jog socket (heartbeats while a key is held, released on
// lift), a key or a "move to" held, its status, and the 3D mouse bound to the robot in
// focus. Everything held is let go when the page hides, the window loses focus, STOP is hit,
// the robot in focus changes or the panel goes; the server halts the robot if the socket
// closes.

import type { ReactiveController, ReactiveControllerHost } from "lit";
import { api } from "../api";
import { control } from "../control";
import { focus } from "../focus";
import { t } from "../i18n";
import { JogSocket, type JogMessage, type JogStatus } from "../jog-socket";
import { feed } from "../live";
import { type Mode, type Stepping, stepOf } from "./axes";

const SENSITIVITY_KEY = "op.mouseSensitivity";

/** What of the panel holds depend on, and where they say why they did not start. */
export interface JogView extends ReactiveControllerHost {
  readonly robot: string;
  readonly mode: Mode;
  readonly stepping: Stepping;
  message: string;
}

export class Jogger implements ReactiveController {
  status: JogStatus | null = null; // of the last press
  movingTo = ""; // the waypoint a held Move to is going to
  freedriving = false; // Freedrive is held
  mouse = ""; // the 3D mouse chosen
  mouseOn = false;
  sensitivity = Number(localStorage.getItem(SENSITIVITY_KEY) ?? "100") || 100;
  private readonly socket = new JogSocket();
  private press = "";
  private boundMouse = "";
  private readonly releaseAll = () => this.socket.releaseAll();
  private readonly onVisibility = () => document.hidden && this.socket.releaseAll();

  /** `told`: what the server says that is not about a press (a waypoint taught with the
   * mouse, the mouse's frame toggled, an error). */
  constructor(
    private readonly host: JogView,
    private readonly told: (message: JogMessage) => void,
  ) {
    host.addController(this);
    this.socket.addEventListener("message", (e) =>
      this.onMessage((e as CustomEvent<JogMessage>).detail));
    this.socket.addEventListener("change", () => {
      if (!this.socket.online) this.status = null; // what was held ended with the link
      this.host.requestUpdate();
    });
  }

  get online(): boolean {
    return this.socket.online;
  }

  async hostConnected(): Promise<void> {
    this.socket.connect();
    document.addEventListener("visibilitychange", this.onVisibility);
    window.addEventListener("blur", this.releaseAll);
    window.addEventListener("op-stop", this.releaseAll);
    try {
      const settings = await api<{ heartbeat_ms: number }>("GET", "/api/jog/settings");
      this.socket.heartbeatMs = settings.heartbeat_ms;
    } catch {
      // keep the default heartbeat period
    }
  }

  hostDisconnected(): void {
    this.socket.releaseAll();
    this.socket.close(); // the server halts anything this page was moving
    document.removeEventListener("visibilitychange", this.onVisibility);
    window.removeEventListener("blur", this.releaseAll);
    window.removeEventListener("op-stop", this.releaseAll);
  }

  hostUpdated(): void {
    // The mouse follows the frame buttons, the speed override and its sensitivity at once.
    if (this.mouseOn && this.mouseBinding() !== this.boundMouse) this.setMouse(true);
  }

  /** Another robot is about to be in focus: nothing held on one carries over to another. */
  leave(): void {
    this.socket.releaseAll();
    if (this.mouseOn) this.setMouse(false);
  }

  private base(): Record<string, unknown> {
    const robot = this.host.robot;
    return { robot, token: control.token(robot), speed: focus.speed / 100 };
  }

  /** False, with the reason said, when this tab does not have control. */
  private mayMove(): boolean {
    this.host.message = "";
    if (control.holds(this.host.robot)) return true;
    this.host.message = t("jog.control.take_first");
    return false;
  }

  /** A jog key held: continuous until release(), or one step. */
  hold(axis: string, direction: number): void {
    if (!this.mayMove()) return;
    const mode = this.host.mode;
    const joint = mode === "joint";
    const step = stepOf(this.host.stepping, mode, axis);
    this.press = this.socket.press(
      {
        type: "jog",
        ...this.base(),
        kind: joint ? "joint" : "cartesian",
        axis: joint ? Number(axis) : axis,
        direction,
        frame: mode === "tool" ? "tool" : "base",
        ...(step === undefined ? {} : { step }),
      },
      step === undefined,
    );
  }

  /** "Move to" a waypoint held. */
  holdWaypoint(name: string): boolean {
    if (!this.mayMove()) return false;
    this.movingTo = name;
    this.press = this.socket.press({ type: "move_to", ...this.base(), waypoint: name });
    return true;
  }

  /** Freedrive held: the arm may be moved by hand until release(). */
  holdFreedrive(): void {
    if (!this.mayMove()) return;
    const { robot, token } = this.base();
    this.freedriving = true;
    this.press = this.socket.press({ type: "freedrive", robot, token });
  }

  release(): void {
    if (this.press) this.socket.release(this.press);
    this.press = "";
    this.movingTo = "";
    this.freedriving = false;
  }

  private onMessage(message: JogMessage): void {
    if (message.type !== "status") {
      this.told(message);
      return;
    }
    this.status = message;
    const over = !["moving", "held"].includes(message.state);
    if (message.press === this.press && over) {
      this.movingTo = "";
      this.freedriving = false;
    }
    if (message.state === "refused" && message.reason === "lease_held") {
      control.forget(this.host.robot);
    }
    if (message.press.startsWith("mouse:") && over) {
      this.mouseOn = false;
      this.boundMouse = "";
    }
    this.host.requestUpdate();
  }

  // 3D mouse -------------------------------------------------------------------------------

  /** The 3D mice connected. */
  mice() {
    return feed.devices.filter((d) => d.kind === "input" && d.status === "connected");
  }

  /** What the mouse should be bound with now, as sent. */
  private mouseBinding(): string {
    const mode = this.host.mode;
    return JSON.stringify({
      type: "mouse",
      ...this.base(),
      speed: (focus.speed / 100) * (this.sensitivity / 100),
      device: this.mouse || this.mice()[0]?.local_name,
      mode: mode === "joint" ? "joint" : "cartesian",
      frame: mode === "tool" ? "tool" : "base",
      buttons: { "0": "teach", "1": "toggle_frame" },
    });
  }

  setMouse(on: boolean): void {
    const device = this.mouse || this.mice()[0]?.local_name;
    if (!device) return;
    if (device !== this.mouse) {
      this.mouse = device;
      this.host.requestUpdate();
    }
    if (on && !control.holds(this.host.robot)) {
      this.host.message = t("jog.control.take_first");
      return;
    }
    if (on !== this.mouseOn) {
      this.mouseOn = on;
      this.host.requestUpdate();
    }
    const binding = this.mouseBinding();
    this.boundMouse = on ? binding : "";
    this.socket.send({ ...JSON.parse(binding), enabled: on });
  }

  changeMouse(device: string): void {
    const on = this.mouseOn;
    if (on) this.setMouse(false); // the mouse that was on lets go first
    this.mouse = device;
    this.host.requestUpdate();
    if (on) this.setMouse(true);
  }

  setSensitivity(percent: number): void {
    this.sensitivity = percent;
    localStorage.setItem(SENSITIVITY_KEY, String(percent));
    this.host.requestUpdate();
  }
}
