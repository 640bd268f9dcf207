import { changeHeld } from "./activity";
import { socketUrl } from "./socket";

// The jog socket: hold-to-run presses with heartbeats, releases, stops and 3D-mouse
// bindings. The server halts the robot if heartbeats stop or this socket closes.

export interface JogStatus {
  type: "status";
  press: string;
  robot: string | null;
  state: "moving" | "stopped" | "halted" | "done" | "refused";
  reason?: string;
  message?: string;
}

export type JogMessage =
  | JogStatus
  | { type: "taught"; robot: string; name: string }
  | { type: "mouse_frame"; device: string; frame: string }
  | { type: "error"; error: { code: string; message: string } };

let counter = 0;

export class JogSocket extends EventTarget {
  online = false;
  heartbeatMs = 33;
  private socket: WebSocket | null = null;
  private held = new Map<string, number>(); // press -> when its last heartbeat went out
  private frame = 0;
  private backup = 0;
  private closed = false;

  connect(): void {
    if (this.socket || this.closed) return;
    const socket = new WebSocket(socketUrl("/api/jog/ws"));
    this.socket = socket;
    socket.onopen = () => {
      this.online = true;
      this.dispatchEvent(new Event("change"));
    };
    socket.onmessage = (event) => {
      const message = JSON.parse(event.data as string) as JogMessage;
      if (message.type === "status" && message.state !== "moving") this.stopBeating(message.press);
      this.dispatchEvent(new CustomEvent<JogMessage>("message", { detail: message }));
    };
    socket.onclose = () => {
      this.socket = null;
      this.online = false;
      for (const press of [...this.held.keys()]) this.stopBeating(press);
      this.dispatchEvent(new Event("change"));
      if (!this.closed) window.setTimeout(() => this.connect(), 1000);
    };
  }

  close(): void {
    this.closed = true;
    this.socket?.close();
  }

  send(message: object): boolean {
    if (!this.socket || this.socket.readyState !== WebSocket.OPEN) return false;
    this.socket.send(JSON.stringify(message));
    return true;
  }

  /** Press: send the press and keep its heartbeat going until release(). */
  press(message: Record<string, unknown>, heartbeat = true): string {
    const press = `ui${Date.now().toString(36)}${(counter++).toString(36)}`;
    if (!this.send({ ...message, press })) return press;
    if (heartbeat) {
      this.held.set(press, performance.now());
      changeHeld(1);
      this.startBeating();
    }
    return press;
  }

  // Heartbeats ride on animation frames: after a touchstart, Chrome holds back timers for
  // about 100 ms (to see whether a scroll begins), but not frames. A timer backs them up.
  // A hidden page gets neither, and the robot stops, as it should.
  private beat = (): void => {
    const now = performance.now();
    for (const [press, last] of this.held) {
      if (now - last >= this.heartbeatMs - 2) {
        this.send({ type: "heartbeat", press });
        this.held.set(press, now);
      }
    }
  };

  private frameBeat = (): void => {
    this.beat();
    this.frame = this.held.size ? requestAnimationFrame(this.frameBeat) : 0;
  };

  private startBeating(): void {
    if (!this.frame) this.frame = requestAnimationFrame(this.frameBeat);
    if (!this.backup) this.backup = window.setInterval(this.beat, this.heartbeatMs);
  }

  release(press: string): void {
    this.stopBeating(press);
    this.send({ type: "release", press });
  }

  releaseAll(): void {
    for (const press of [...this.held.keys()]) this.release(press);
  }

  private stopBeating(press: string): void {
    if (!this.held.delete(press)) return;
    changeHeld(-1);
    if (!this.held.size) {
      cancelAnimationFrame(this.frame);
      window.clearInterval(this.backup);
      this.frame = this.backup = 0;
    }
  }
}
