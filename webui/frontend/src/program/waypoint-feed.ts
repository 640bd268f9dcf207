// Waypoints taught, renamed or deleted anywhere (the Jog panel, another pendant, the API)
// reach the program dropdowns at once, from the variable storage's change events. On every
// (re)connection the caller reads the whole list again: events missed meanwhile are lost.

import { retryDelay, socketUrl } from "../socket";

const WAYPOINT_TYPES = new Set(["joint_waypoint", "pose_waypoint"]);

export interface WaypointChange {
  name: string;
  present: boolean;
}

interface VariableEvent {
  type?: unknown;
  variable?: { name?: unknown; type?: unknown };
}

export class WaypointFeed {
  private socket: WebSocket | null = null;
  private retry = 0;
  private stopped = true;

  constructor(
    private readonly onChange: (change: WaypointChange) => void,
    private readonly onConnect: () => void,
  ) {}

  start(): void {
    this.stopped = false;
    if (this.socket) return;
    const socket = new WebSocket(socketUrl("/api/variables/_events"));
    this.socket = socket;
    socket.onopen = () => {
      this.retry = 0;
      this.onConnect();
    };
    socket.onmessage = (event) => {
      let message: VariableEvent;
      try {
        message = JSON.parse(event.data as string) as VariableEvent;
      } catch {
        return;
      }
      const variable = message.variable;
      if (typeof variable?.name !== "string" || !WAYPOINT_TYPES.has(String(variable.type))) return;
      if (message.type === "changed") this.onChange({ name: variable.name, present: true });
      if (message.type === "deleted") this.onChange({ name: variable.name, present: false });
    };
    socket.onclose = () => {
      this.socket = null;
      if (this.stopped) return;
      window.setTimeout(() => this.start(), retryDelay(this.retry++));
    };
  }

  stop(): void {
    this.stopped = true;
    this.socket?.close();
    this.socket = null;
  }
}
