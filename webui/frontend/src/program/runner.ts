// The runs of the program on show in the Program panel: its run status and output from the
// run feed (while the panel is on the page), the running block highlighted on the blocks,
// starting a run with the breakpoints and the control leases this tab holds, pause, resume,
// step, stop, and breakpoints changed during a run. Errors are thrown: the panel says them.

import type { ReactiveController, ReactiveControllerHost } from "lit";
import { client, ok } from "../api";
import { control } from "../control";
import { focus } from "../focus";
import { feed } from "../live";
import type { ProgramEditor } from "./editor";
import { RunFeed, type RunView } from "./run-feed";
import { LIVE_STATES, type RunStatus } from "./types";

export type RunCommand = "pause" | "resume" | "step" | "stop";

const runs = new RunFeed();

export class ProgramRunner implements ReactiveController {
  private highlighted: string | null = null;

  /** `program`: the name of the program on show ("" before its first save). */
  constructor(
    private readonly host: ReactiveControllerHost,
    private readonly program: () => string,
    private readonly editor: () => ProgramEditor | null,
  ) {
    host.addController(this);
  }

  private readonly onRuns = (event: Event) => {
    if ((event as CustomEvent<string>).detail === this.program()) this.show();
  };

  hostConnected(): void {
    runs.addEventListener("change", this.onRuns);
    runs.start();
  }

  hostDisconnected(): void {
    runs.removeEventListener("change", this.onRuns);
    runs.stop();
  }

  /** The latest status and the output of the program's run, if it has run. */
  view(): RunView | undefined {
    const name = this.program();
    return name ? runs.view(name) : undefined;
  }

  status(): RunStatus | undefined {
    return this.view()?.status;
  }

  /** A run is starting, running or paused. */
  live(): boolean {
    return LIVE_STATES.includes(this.status()?.state ?? "idle");
  }

  /** Another program is on show (or none yet): nothing of it is highlighted. */
  forget(): void {
    this.highlighted = null;
  }

  async fetchStatus(name: string): Promise<void> {
    const status = await ok(client.GET("/api/programs/{name}/status",
      { params: { path: { name } } })).catch(() => null);
    if (status) runs.answer(status);
    this.show();
  }

  /** Runs the saved program on the robot in focus (until a "use robot" block), with the
   * leases this tab holds (robots, and any other device a panel took control of). */
  async start(): Promise<void> {
    const robot = focus.robot;
    const leases: Record<string, string> = {};
    for (const device of feed.devices) {
      const token = control.token(device.local_name);
      if (token) leases[device.local_name] = token;
    }
    const status = await ok(client.POST("/api/programs/{name}/run", {
      params: { path: { name: this.program() } },
      body: { breakpoints: this.editor()?.liveBreakpoints() ?? [], leases, robot: robot || null },
    }));
    runs.answer(status);
  }

  async command(action: RunCommand): Promise<void> {
    const name = this.program();
    if (action === "stop" && runs.sendStop(name)) return; // its outcome is pushed
    await ok(client.POST(`/api/programs/{name}/${action}`, { params: { path: { name } } }));
  }

  /** Breakpoints set or cleared while it runs apply to the run at once. */
  async syncBreakpoints(): Promise<void> {
    const editor = this.editor();
    const status = this.status();
    if (editor && status && LIVE_STATES.includes(status.state)) {
      await ok(client.PUT("/api/programs/{name}/breakpoints", {
        params: { path: { name: this.program() } },
        body: { ids: editor.liveBreakpoints() },
      }));
    }
  }

  /** The run's block highlighted on the workspace. */
  private show(): void {
    const status = this.status();
    const live = status !== undefined && LIVE_STATES.includes(status.state);
    const block = live ? status.block : null;
    if (block !== this.highlighted) {
      this.highlighted = block;
      this.editor()?.highlight(block);
    }
    this.host.requestUpdate();
    if (status?.state === "error" && status.error?.block) this.editor()?.reveal(status.error.block);
  }
}
