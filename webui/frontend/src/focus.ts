// The robot in focus, one for the whole UI: the status bar shows it, the Jog, Scene and
// Program panels act on it, the 3D views draw it, STOP and the speed override apply to it.
// It changes only when the user chooses another robot (or the chosen one is removed); a
// robot added later never takes the focus by itself. With none chosen, a single robot is in
// focus; with several, the user is asked.

import type { ReactiveController, ReactiveControllerHost } from "lit";
import { feed } from "./live";

const ROBOT_KEY = "op.robot";
const SPEED_KEY = "op.speed";

export class Focus extends EventTarget {
  private chosen = localStorage.getItem(ROBOT_KEY) ?? "";
  /** The speed override in percent: the jog speed, and the speed of a running program. */
  speed = Number(localStorage.getItem(SPEED_KEY) ?? "25") || 25;

  /** The robot in focus, "" when there is none (no robot, or several and none chosen). */
  get robot(): string {
    const robots = feed.robots().map((r) => r.local_name);
    if (robots.includes(this.chosen)) return this.chosen;
    if (robots.length !== 1) return "";
    // The only robot is in focus, and stays so when another is added.
    this.chosen = robots[0];
    localStorage.setItem(ROBOT_KEY, this.chosen);
    return this.chosen;
  }

  choose(robot: string): void {
    if (robot === this.chosen) return;
    this.chosen = robot;
    localStorage.setItem(ROBOT_KEY, robot);
    this.dispatchEvent(new Event("change"));
  }

  setSpeed(percent: number): void {
    this.speed = Math.min(100, Math.max(1, Math.round(percent)));
    localStorage.setItem(SPEED_KEY, String(this.speed));
    this.dispatchEvent(new Event("change"));
  }
}

export const focus = new Focus();

/** Re-renders its host when the focus or the speed override changes. */
export class FocusController implements ReactiveController {
  private readonly update = () => this.host.requestUpdate();

  constructor(private readonly host: ReactiveControllerHost) {
    host.addController(this);
  }

  hostConnected(): void {
    focus.addEventListener("change", this.update);
  }

  hostDisconnected(): void {
    focus.removeEventListener("change", this.update);
  }
}
