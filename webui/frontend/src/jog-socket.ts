import { changeHeld } from "./activity";
import { client, ok } from "./api";
import type { Words } from "./i18n/words";
import { session } from "./session";
import { closeSocket, SIGN_IN_ENDED, socketUrl } from "./socket";

// The jog socket: hold-to-run presses with heartbeats, releases, stops and 3D-mouse
// bindings. The server halts the robot if heartbeats stop or this socket closes.

export interface JogStatus {
  type: "status";
  press: string;
  robot: string | null;
  state: "moving" | "held" | "stopped" | "halted" | "done" | "refused";
  reason?: string;
  message?: string;
  words?: Words | null; // the message as the chosen language says it
}

export type JogMessage =
  | JogStatus
  | { type: "taught"; robot: string; name: string }
  | { type: "mouse_frame"; device: string; frame: string; mode: "joint" | "cartesian" }
  | { type: "error"; error: { code: string; message: string; words?: Words } };

let counter = 0;
let direct: string | null = null;

// Hold-to-run goes straight to the jog service's own port when it has one: heartbeats must
// never wait behind the gateway's HTTP traffic. Through the gateway otherwise. The jog port
// is opened with a short-lived ticket the gateway gives the signed-in user.
async function jogSocketUrl(): Promise<string> {
  try {
    if (!direct) {
      const settings = await ok(client.GET("/api/jog/settings"));
      if (settings.socket_port) direct = socketUrl("/jog/ws", settings.socket_port);
    }
    if (direct) {
      const { ticket } = await ok(client.POST("/api/auth/ticket"));
      return `${direct}?ticket=${encodeURIComponent(ticket)}`;
    }
  } catch {
    // the runtime is not answering yet, or this user may not jog: the gateway's socket
    // says which
  }
  return socketUrl("/api/jog/ws");
}

export class JogSocket extends EventTarget {
  online = false;
  heartbeatMs = 33;
  private socket: WebSocket | null = null;
  private held = new Map<string, number>(); // press -> when its last heartbeat went out
  private frame = 0;
  private backup = 0;
  private closed = false;
  private connecting = false;

  connect(): void {
    if (this.socket || this.closed || this.connecting) return;
    this.connecting = true;
    void jogSocketUrl().then((url) => {
      this.connecting = false;
      if (!this.socket && !this.closed) this.open(url);
    });
  }

  private open(url: string): void {
    const socket = new WebSocket(url);
    this.socket = socket;
    socket.onopen = () => {
      this.online = true;
      this.dispatchEvent(new Event("change"));
    };
    socket.onmessage = (event) => {
      const message = JSON.parse(event.data as string) as JogMessage;
      // "held": still pressed, held back (an obstacle, a limit): the heartbeat goes on.
      const live = message.type === "status" && (message.state === "moving" || message.state === "held");
      if (message.type === "status" && !live) this.stopBeating(message.press);
      this.dispatchEvent(new CustomEvent<JogMessage>("message", { detail: message }));
    };
    socket.onclose = (event) => {
      this.socket = null;
      this.online = false;
      direct = null; // a restarted runtime may listen on another port: ask again
      for (const press of [...this.held.keys()]) this.stopBeating(press);
      this.dispatchEvent(new Event("change"));
      if (event.code === SIGN_IN_ENDED) {
        // The sign-in that opened it ended: the session ends here too, saying why, and the
        // socket is not opened again (a ticket's own refusal leaves the session standing).
        void session.lost().then(() => session.me && !this.closed && this.connect());
        return;
      }
      if (!this.closed) window.setTimeout(() => this.connect(), 1000);
    };
  }

  close(): void {
    this.closed = true;
    closeSocket(this.socket);
  }

  send(message: object): boolean {
    if (this.closed || !this.socket || this.socket.readyState !== WebSocket.OPEN) return false;
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
