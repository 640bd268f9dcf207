// WebSockets to the runtime: the URL for a path on this page's host, the wait before a
// dropped socket tries again (doubling from 0.5 s, at most 2 s: a page is usable again soon
// after the runtime is back), and a socket that does so.

import { session } from "./session";

/** The close code of a socket whose sign-in ended (signed out, revoked, expired). */
export const SIGN_IN_ENDED = 4401;

export function socketUrl(path: string, port?: number): string {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const host = port ? `${location.hostname}:${port}` : location.host;
  return `${scheme}://${host}${path}`;
}

/** Closes a socket. One still connecting is closed once open instead: closing it while it
 * connects drops its handshake half-way, which the browser reports as an error. Nothing it
 * carries reaches the page after this. */
export function closeSocket(socket: WebSocket | null | undefined): void {
  if (!socket) return;
  socket.onmessage = null;
  if (socket.readyState === WebSocket.CONNECTING) socket.onopen = () => socket.close();
  else socket.close();
}

export function retryDelay(attempt: number): number {
  return Math.min(500 * 2 ** attempt, 2000);
}

/** A socket to a path on this host that reconnects itself until stopped. */
export class ReconnectingSocket {
  private socket: WebSocket | null = null;
  private retry = 0;
  private stopped = true;

  constructor(
    private readonly path: string,
    private readonly onMessage: (data: string) => void,
    private readonly onOpen: () => void = () => undefined,
  ) {}

  start(): void {
    this.stopped = false;
    if (this.socket) return;
    const socket = new WebSocket(socketUrl(this.path));
    this.socket = socket;
    socket.onopen = () => {
      this.retry = 0;
      this.onOpen();
    };
    socket.onmessage = (event) => this.onMessage(String(event.data));
    socket.onclose = (event) => {
      if (event.code === SIGN_IN_ENDED) session.lost();
      if (this.socket !== socket) return; // stopped, and maybe started again since
      this.socket = null;
      if (this.stopped) return;
      window.setTimeout(() => this.start(), retryDelay(this.retry++));
    };
  }

  /** False when the socket is not open (nothing sent). */
  send(text: string): boolean {
    if (this.socket?.readyState !== WebSocket.OPEN) return false;
    this.socket.send(text);
    return true;
  }

  stop(): void {
    this.stopped = true;
    closeSocket(this.socket);
    this.socket = null;
  }
}
