// One WebSocket to the device manager: detected devices, added devices with their status,
// and the live state of each. Reconnects by itself; views re-render once per frame at most.
// The runtime sends frames of everything that changed and the next ones only when this
// page acknowledges them, once per frame it draws: states come as fast as this device can
// show them, and what it cannot show is dropped at the runtime, never queued here.

import type { ReactiveController, ReactiveControllerHost } from "lit";
import { session } from "./session";
import { retryDelay, SIGN_IN_ENDED, socketUrl } from "./socket";
import type { AddedDevice, DetectedDevice, InputState, RobotState } from "./types";

type Message =
  | { type: "detected"; detected: DetectedDevice[] }
  | { type: "devices"; devices: AddedDevice[] }
  | { type: "state"; device: string; state: RobotState }
  | { type: "error"; error: { message: string } };

export class DeviceFeed extends EventTarget {
  detected: DetectedDevice[] = [];
  devices: AddedDevice[] = [];
  states = new Map<string, RobotState>();
  online = false;
  private socket: WebSocket | null = null;
  private frame = 0;
  private retry = 0;
  private unacked = 0;

  constructor(private readonly path = "/api/devices/ws?batch=1") {
    super();
  }

  /** The added robots, connected or not. */
  robots(): AddedDevice[] {
    return this.devices.filter((d) => d.kind === "robot");
  }

  /** The live state of an input device (a 3D mouse), whose states come on this feed too. */
  inputState(name: string): InputState | null {
    const state = this.states.get(name) as unknown as InputState | undefined;
    return state && Array.isArray(state.axes) ? state : null;
  }

  start(): void {
    if (this.socket) return;
    const socket = new WebSocket(socketUrl(this.path));
    this.socket = socket;
    socket.onopen = () => {
      this.online = true;
      this.retry = 0;
      this.changed();
    };
    socket.onmessage = (event) => {
      this.unacked++;
      this.receive(event.data as string);
      this.changed(); // the acknowledgement goes with the next drawn frame
    };
    socket.onclose = (event) => {
      if (event.code === SIGN_IN_ENDED) session.lost();
      this.socket = null;
      this.online = false;
      this.unacked = 0;
      this.states.clear();
      this.changed();
      window.setTimeout(() => this.start(), retryDelay(this.retry++));
    };
  }

  private receive(text: string): void {
    let messages: Message[];
    try {
      const parsed = JSON.parse(text) as Message | Message[];
      messages = Array.isArray(parsed) ? parsed : [parsed];
    } catch {
      return;
    }
    for (const message of messages) this.apply(message);
  }

  private apply(message: Message): void {
    switch (message.type) {
      case "detected":
        this.detected = message.detected;
        break;
      case "devices":
        this.devices = message.devices;
        for (const name of [...this.states.keys()]) {
          const device = this.devices.find((d) => d.local_name === name);
          if (!device || device.status !== "connected") this.states.delete(name);
        }
        break;
      case "state":
        this.states.set(message.device, message.state);
        break;
      default:
        return;
    }
  }

  private changed(): void {
    if (this.frame) return;
    this.frame = requestAnimationFrame(() => {
      this.frame = 0;
      this.dispatchEvent(new Event("change"));
      for (; this.unacked > 0; this.unacked--) {
        if (this.socket?.readyState === WebSocket.OPEN) this.socket.send('{"type":"ack"}');
      }
    });
  }
}

export const feed = new DeviceFeed();

/** Re-renders its host whenever the feed changes, for as long as the host is on the page. */
export class FeedController implements ReactiveController {
  private readonly update = () => this.host.requestUpdate();

  constructor(private readonly host: ReactiveControllerHost) {
    host.addController(this);
  }

  hostConnected(): void {
    feed.addEventListener("change", this.update);
  }

  hostDisconnected(): void {
    feed.removeEventListener("change", this.update);
  }
}
