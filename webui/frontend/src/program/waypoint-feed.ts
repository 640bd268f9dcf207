// Waypoints taught, renamed or deleted anywhere (the Jog panel, another pendant, the API)
// reach the program dropdowns at once, from the variable storage's change events. On every
// (re)connection the caller reads the whole list again: events missed meanwhile are lost.

import { ReconnectingSocket } from "../socket";

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
  private readonly socket: ReconnectingSocket;

  constructor(onChange: (change: WaypointChange) => void, onConnect: () => void) {
    this.socket = new ReconnectingSocket(
      "/api/variables/_events",
      (data) => {
        let message: VariableEvent;
        try {
          message = JSON.parse(data) as VariableEvent;
        } catch {
          return;
        }
        const variable = message.variable;
        if (typeof variable?.name !== "string" || !WAYPOINT_TYPES.has(String(variable.type))) {
          return;
        }
        if (message.type === "changed") onChange({ name: variable.name, present: true });
        if (message.type === "deleted") onChange({ name: variable.name, present: false });
      },
      onConnect,
    );
  }

  start(): void {
    this.socket.start();
  }

  stop(): void {
    this.socket.stop();
  }
}
