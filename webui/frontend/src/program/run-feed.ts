// The program service's run statuses over one WebSocket: the latest status of each program
// and the output of its current run, gaps filled from GET status?after=N. Reconnects itself.

import { client, ok } from "../api";
import { ReconnectingSocket } from "../socket";
import type { OutputEntry, RunStatus } from "./types";

const MAX_KEPT_OUTPUT = 2000;

export interface RunView {
  status: RunStatus;
  output: OutputEntry[];
}

export class RunFeed extends EventTarget {
  private readonly views = new Map<string, RunView>();
  private readonly socket = new ReconnectingSocket("/api/programs/_ws", (data) => {
    try {
      this.receive(JSON.parse(data) as RunStatus);
    } catch {
      // Not a status: nothing to show.
    }
  });

  view(program: string): RunView | undefined {
    return this.views.get(program);
  }

  start(): void {
    this.socket.start();
  }

  /** A program's stop over the open socket (no HTTP request on the way); false when the
   * socket is not open, and the caller asks over HTTP. */
  sendStop(program: string): boolean {
    return this.socket.send(JSON.stringify({ type: "stop", program }));
  }

  stop(): void {
    this.socket.stop();
  }

  /** The answer to a run request: the new run shows at once. Answers about a run already
   * shown are left to the push, which is in order (an answer can cross a newer push). */
  answer(status: RunStatus): void {
    if (this.views.get(status.program)?.status.run !== status.run) this.receive(status);
  }

  private receive(status: RunStatus): void {
    if (typeof status.program !== "string" || typeof status.state !== "string") return;
    const known = this.views.get(status.program);
    const sameRun = known !== undefined && known.status.run === status.run;
    const output = sameRun ? known.output : [];
    const last = output.at(-1)?.seq ?? 0;
    const first = status.output[0]?.seq;
    if (first !== undefined && first > last + 1) void this.fill(status.program, status.run, last);
    for (const line of status.output) if (line.seq > (output.at(-1)?.seq ?? 0)) output.push(line);
    if (output.length > MAX_KEPT_OUTPUT) output.splice(0, output.length - MAX_KEPT_OUTPUT);
    this.views.set(status.program, { status: { ...status, output: [] }, output });
    this.dispatchEvent(new CustomEvent("change", { detail: status.program }));
  }

  /** Lines the push left out (it carries the latest ones only). */
  private async fill(program: string, run: number, after: number): Promise<void> {
    const status = await ok(client.GET("/api/programs/{name}/status", {
      params: { path: { name: program }, query: { after } },
    })).catch(() => null);
    const view = this.views.get(program);
    if (!status || !view || view.status.run !== run || status.run !== run) return;
    const merged = new Map(view.output.map((o) => [o.seq, o]));
    for (const line of status.output) merged.set(line.seq, line);
    view.output = [...merged.values()].sort((a, b) => a.seq - b.seq).slice(-MAX_KEPT_OUTPUT);
    this.dispatchEvent(new CustomEvent("change", { detail: program }));
  }
}
