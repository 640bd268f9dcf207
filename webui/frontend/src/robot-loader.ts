// When a panel (re)loads what it shows of the robot in focus (its model, waypoints, scene):
// when the focus changes, when the runtime or the robot's link comes back after a loss, and
// again a moment after a load that failed. A page left open through a runtime restart is
// usable again as soon as the runtime answers, without a reload or a tab switch.

import type { ReactiveController, ReactiveControllerHost } from "lit";
import { focus } from "./focus";
import { feed } from "./live";

const RETRY_MS = 1000;

export class RobotLoader implements ReactiveController {
  private robot = "";
  private live = false;
  private loaded = "";
  private loading = false;
  private retry = 0;

  /**
   * `load` answers whether it loaded everything; a false answer is retried. Nothing is
   * loaded while `wanted` says it is not shown (the host asks for an update when it is).
   */
  constructor(
    private readonly host: ReactiveControllerHost,
    private readonly load: (robot: string) => Promise<boolean>,
    private readonly wanted: () => boolean = () => true,
  ) {
    host.addController(this);
  }

  hostUpdate(): void {
    const robot = focus.robot;
    const live = feed.online &&
      feed.robots().some((d) => d.local_name === robot && d.status === "connected");
    if (robot !== this.robot || (live && !this.live)) this.loaded = "";
    this.robot = robot;
    this.live = live;
    if (!robot || !feed.online || this.loading || this.retry || this.loaded === robot) return;
    if (!this.wanted()) return;
    this.loading = true;
    void this.load(robot).then((ok) => {
      this.loading = false;
      if (ok) this.loaded = robot;
      else this.retry = window.setTimeout(() => {
        this.retry = 0;
        this.host.requestUpdate();
      }, RETRY_MS);
      this.host.requestUpdate();
    });
  }

  hostDisconnected(): void {
    window.clearTimeout(this.retry);
    this.retry = 0;
    this.loaded = ""; // shown again later: load afresh
  }
}
