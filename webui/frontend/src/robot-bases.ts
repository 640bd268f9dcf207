// Where each robot stands in the world: its frame `frames.<robot>` in the variable storage,
// the identity without one (runtime/cell/bases.py: the frame motion, jog and collision
// checking place it by). Followed live from the storage's change events by one socket for
// every 3D view on the page; read whole at every (re)connection, since events missed while
// it was down are lost.

import { client, ok } from "./api";
import { ReconnectingSocket } from "./socket";
import type { PoseJson } from "./three/scene";

const PREFIX = "frames.";

interface StoredVariable {
  name: string;
  type: string;
  value: unknown;
}

interface VariableEvent {
  type?: unknown;
  variable?: StoredVariable;
}

/** A frame's pose, or null for what is not a frame (the motion service refuses those). */
function poseOf(variable: StoredVariable): PoseJson | null {
  if (variable.type !== "frame") return null;
  const pose = (variable.value as { pose?: PoseJson } | null)?.pose;
  return pose && Array.isArray(pose.position) && Array.isArray(pose.orientation) ? pose : null;
}

export class RobotBases extends EventTarget {
  private frames = new Map<string, PoseJson>(); // by robot
  private users = 0;
  private round = 0;
  private pending: VariableEvent[] | null = null; // events that came while a read was under way
  private readonly socket = new ReconnectingSocket(
    "/api/variables/_events",
    (data) => this.received(data),
    () => void this.read(),
  );

  /** The robot's base in the world; null is the identity (no frame stored). */
  base(robot: string): PoseJson | null {
    return this.frames.get(robot) ?? null;
  }

  /** Follows the frames while anyone uses them; the returned function ends this use. */
  use(): () => void {
    if (this.users++ === 0) this.socket.start();
    let used = true;
    return () => {
      if (!used) return;
      used = false;
      if (--this.users > 0) return;
      this.socket.stop();
      this.round++; // a read under way answers no one now
      this.pending = null;
    };
  }

  private async read(): Promise<void> {
    const round = ++this.round;
    this.pending = [];
    let frames: StoredVariable[];
    try {
      frames = await ok(client.GET("/api/variables", { params: { query: { type: "frame" } } }));
    } catch {
      if (round === this.round) this.pending = null; // the events alone until the next connection
      return;
    }
    if (round !== this.round) return;
    const events = this.pending ?? [];
    this.pending = null;
    this.frames.clear();
    for (const variable of frames) this.apply({ type: "changed", variable });
    // Events that came meanwhile, in their order: the last word on each frame wins.
    for (const event of events) this.apply(event);
    this.dispatchEvent(new Event("change"));
  }

  private received(data: string): void {
    let event: VariableEvent;
    try {
      event = JSON.parse(data) as VariableEvent;
    } catch {
      return;
    }
    if (typeof event.variable?.name !== "string" || !event.variable.name.startsWith(PREFIX)) return;
    if (this.pending) this.pending.push(event);
    else if (this.apply(event)) this.dispatchEvent(new Event("change"));
  }

  /** Whether the event changed a base. */
  private apply(event: VariableEvent): boolean {
    const variable = event.variable;
    if (!variable?.name.startsWith(PREFIX)) return false;
    const robot = variable.name.slice(PREFIX.length);
    const pose = event.type === "changed" ? poseOf(variable) : null;
    const before = this.frames.get(robot);
    if (pose) this.frames.set(robot, pose);
    else this.frames.delete(robot);
    return JSON.stringify(before ?? null) !== JSON.stringify(pose);
  }
}

export const robotBases = new RobotBases();
