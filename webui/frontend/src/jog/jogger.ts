// Hold-to-run on the Jog panel: the jog socket (heartbeats while a key is held, released on
// lift), a key or a "move to" held, its status, and the 3D mouse bound to the robot in
// focus. Everything held is let go when the page hides, the window loses focus, STOP is hit,
// the robot in focus changes or the panel goes; the server halts the robot if the socket
// closes.

import type { ReactiveController, ReactiveControllerHost } from "lit";
import { client, ok } from "../api";
import { control } from "../control";
import { focus } from "../focus";
import { holdStarting } from "../components/hold-button";
import { t } from "../i18n";
import { worded } from "../i18n/words";
import { JogSocket, type JogMessage, type JogStatus } from "../jog-socket";
import { feed } from "../live";
import { tell } from "../rights";
import { session } from "../session";
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
  mouseAway = false; // on, but the mouse is gone: the robot halted until it is back
  mouseOff = ""; // why the mouse went off by itself (a lost robot link, a stuck cap)
  sensitivity = Number(localStorage.getItem(SENSITIVITY_KEY) ?? "100") || 100;
  private readonly socket = new JogSocket();
  private press = "";
  // The button a press began on: a refusal, or a halt, is said there (where the finger is).
  private pressedOn: { press: string; button: HTMLElement } | null = null;
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
    // A role that may not jog opens no socket the gateway would refuse (its keys say why).
    if (session.may("WS", "/api/jog/ws")) this.socket.connect();
    document.addEventListener("visibilitychange", this.onVisibility);
    window.addEventListener("blur", this.releaseAll);
    window.addEventListener("op-stop", this.releaseAll);
    try {
      const settings = await ok(client.GET("/api/jog/settings"));
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
    const button = holdStarting();
    if (button) tell(this.host.message, button);
    return false;
  }

  /** A press just sent from the hold button being pressed (if one is). */
  private pressed(press: string): string {
    const button = holdStarting();
    this.pressedOn = button ? { press, button } : null;
    return press;
  }

  /** A jog key held: continuous until release(), or one step. */
  hold(axis: string, direction: number): void {
    if (!this.mayMove()) return;
    const mode = this.host.mode;
    const joint = mode === "joint";
    const step = stepOf(this.host.stepping, mode, axis);
    this.press = this.pressed(this.socket.press(
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
    ));
  }

  /** "Move to" a waypoint held. */
  holdWaypoint(name: string): boolean {
    if (!this.mayMove()) return false;
    this.movingTo = name;
    this.press = this.pressed(
      this.socket.press({ type: "move_to", ...this.base(), waypoint: name }),
    );
    return true;
  }

  /** Freedrive held: the arm may be moved by hand until release(). */
  holdFreedrive(): void {
    if (!this.mayMove()) return;
    const { robot, token } = this.base();
    this.freedriving = true;
    this.press = this.pressed(this.socket.press({ type: "freedrive", robot, token }));
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
    const on = this.pressedOn;
    if (on && message.press === on.press && ["refused", "halted"].includes(message.state)) {
      this.pressedOn = null;
      const reason = worded(message.message || message.reason || "", message.words);
      tell(t(message.state === "refused" ? "jog.refused" : "jog.halted", { reason }), on.button);
    }
    if (message.press === `mouse:${this.mouse}`) this.mouseSaid(message, over);
    this.host.requestUpdate();
  }

  // 3D mouse -------------------------------------------------------------------------------

  /** What the jog service says of the mouse's binding. One that waits for its mouse stays
   * on; one that ended without the switch being tapped says why on the mouse's card. */
  private mouseSaid(message: JogStatus, over: boolean): void {
    this.mouseAway = !over && message.state === "held" && message.reason === "mouse_away";
    if (!over) return;
    const why = message.message || message.reason || message.state;
    if (this.mouseOn) this.mouseOff = worded(why, message.words);
    this.mouseOn = false;
    this.boundMouse = "";
  }

  /** Under the switch: waiting for the mouse, or why it went off by itself. */
  mouseNote(): string {
    if (this.mouseOn) return this.mouseAway ? t("jog.mouse.waiting") : "";
    return this.mouseOff ? t("jog.mouse.off_because", { reason: this.mouseOff }) : "";
  }

  /** The 3D mice connected, and the one switched on while it is away. */
  mice() {
    return feed.devices.filter((d) => d.kind === "input"
      && (d.status === "connected" || (this.mouseOn && d.local_name === this.mouse)));
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
    this.mouseOff = "";
    if (!on) this.mouseAway = false;
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
