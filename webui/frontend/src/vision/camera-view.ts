import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { SIGN_IN_ENDED, closeSocket, retryDelay, socketUrl } from "../socket";
import { session } from "../session";
import { shared } from "../styles";

// A camera's live picture (its frames relayed by the device manager), with what the Vision
// panel lays over it: boxes of detections, corners found, the calibration's coverage map,
// and, while `drawing`, a box the user draws with a finger (image pixels, for a template).
// The next frame is asked for only once this one is drawn: a slow tablet shows the newest
// picture, never a queue of old ones.

export interface Box {
  x: number;
  y: number;
  width: number;
  height: number;
}

export interface Mark extends Box {
  label?: string;
  tone?: "ok" | "warn";
}

export interface Overlay {
  boxes?: Mark[];
  points?: number[][];
  coverage?: { rows: number; columns: number; cells: number[][] };
}

interface FrameAbout {
  seqno: number;
  ts: number;
  width: number;
  height: number;
}

const MIN_BOX = 8; // px of the image: a smaller drag is a tap
const KEPT_LATENCIES = 600;

export class OpCameraView extends LitElement {
  static properties = {
    camera: { type: String },
    overlay: { attribute: false },
    drawing: { type: Boolean },
    problem: { state: true },
    size: { state: true },
  };
  declare camera: string;
  declare overlay: Overlay;
  declare drawing: boolean;
  declare problem: string;
  declare size: [number, number] | null;

  /** Frames drawn since this view opened, and for each how long from taken to drawn (s):
   * read by the benchmark of the camera-to-UI latency. */
  frames = 0;
  latencies: number[] = [];
  private socket: WebSocket | null = null;
  private streaming = "";
  private retry = 0;
  private retryTimer = 0;
  private about: FrameAbout | null = null;
  private bitmap: ImageBitmap | null = null;
  private drag: { x0: number; y0: number; x1: number; y1: number; pointer: number } | null = null;
  private drawn: Box | null = null;

  static styles = [
    shared,
    css`
      :host {
        display: block;
        position: relative;
      }
      canvas {
        display: block;
        width: 100%;
        max-height: 64vh;
        aspect-ratio: var(--aspect, 16 / 10);
        object-fit: contain;
        background: #111;
        border-radius: 10px;
      }
      canvas.drawing {
        touch-action: none;
        cursor: crosshair;
        outline: 3px dashed var(--accent);
      }
      .problem {
        position: absolute;
        inset: auto 12px 12px 12px;
        margin: 0;
        padding: 8px 12px;
        border-radius: 8px;
        background: var(--bad-bg);
        color: var(--bad-fg);
      }
    `,
  ];

  constructor() {
    super();
    this.camera = "";
    this.overlay = {};
    this.drawing = false;
    this.problem = "";
    this.size = null;
  }

  connectedCallback(): void {
    super.connectedCallback();
    if (this.camera && !this.streaming) this.open(); // attached again
  }

  disconnectedCallback(): void {
    super.disconnectedCallback();
    this.close();
  }

  /** The box drawn last (image px), until `clearBox`. */
  get box(): Box | null {
    return this.drawn;
  }

  clearBox(): void {
    this.drawn = null;
    this.paint();
  }

  protected updated(changed: Map<string, unknown>): void {
    if (changed.has("camera") && this.camera !== this.streaming) this.open();
    if (changed.has("drawing") && !this.drawing) this.drag = null;
    this.paint();
  }

  private close(): void {
    window.clearTimeout(this.retryTimer);
    this.streaming = "";
    const socket = this.socket;
    this.socket = null;
    closeSocket(socket);
  }

  private open(): void {
    this.close();
    // Nothing of the last camera's picture is shown as this one's.
    this.bitmap?.close();
    this.bitmap = null;
    this.about = null;
    this.drawn = null;
    this.problem = "";
    this.size = null;
    const canvas = this.canvas;
    canvas?.getContext("2d")?.clearRect(0, 0, canvas.width, canvas.height);
    if (!this.camera) return;
    const camera = this.camera;
    this.streaming = camera;
    const path = `/api/devices/${encodeURIComponent(camera)}/frames/ws?encoding=jpeg&quality=75`;
    const socket = new WebSocket(socketUrl(path));
    socket.binaryType = "blob";
    this.socket = socket;
    socket.onmessage = (event) => void this.received(socket, event.data);
    socket.onclose = (event) => {
      if (this.socket !== socket) return;
      this.socket = null;
      if (event.code === SIGN_IN_ENDED) session.lost();
      if (!this.problem) this.problem = t("vision.view.lost");
      this.retryTimer = window.setTimeout(() => {
        if (this.streaming === camera && this.isConnected) this.open();
      }, retryDelay(this.retry++));
    };
  }

  private async received(socket: WebSocket, data: unknown): Promise<void> {
    if (typeof data === "string") {
      const message = JSON.parse(data) as FrameAbout & { type?: string; error?: { message: string } };
      if (message.type === "error") this.problem = message.error?.message ?? t("vision.view.lost");
      else this.about = message;
      return;
    }
    const about = this.about;
    let bitmap: ImageBitmap;
    try {
      bitmap = await createImageBitmap(data as Blob);
    } catch {
      socket.send("drawn"); // a frame that does not decode is skipped, not waited on
      return;
    }
    if (this.socket !== socket) {
      bitmap.close();
      return;
    }
    this.bitmap?.close();
    this.bitmap = bitmap;
    this.retry = 0;
    this.problem = "";
    if (this.size?.[0] !== bitmap.width || this.size?.[1] !== bitmap.height) {
      this.size = [bitmap.width, bitmap.height];
    }
    this.paint();
    this.frames += 1;
    if (about) {
      this.latencies.push(Date.now() / 1000 - about.ts);
      if (this.latencies.length > KEPT_LATENCIES) this.latencies.shift();
    }
    this.dataset.frames = String(this.frames);
    // The next frame once this one is on the screen (none while the page is hidden).
    requestAnimationFrame(() => {
      if (socket.readyState === WebSocket.OPEN) socket.send("drawn");
    });
  }

  private get canvas(): HTMLCanvasElement | null {
    return this.renderRoot.querySelector("canvas");
  }

  private paint(): void {
    const canvas = this.canvas;
    const bitmap = this.bitmap;
    if (!canvas || !bitmap) return;
    if (canvas.width !== bitmap.width) canvas.width = bitmap.width;
    if (canvas.height !== bitmap.height) canvas.height = bitmap.height;
    const ctx = canvas.getContext("2d");
    if (!ctx) return;
    ctx.drawImage(bitmap, 0, 0);
    const line = Math.max(2, bitmap.width / 400);
    const coverage = this.overlay.coverage;
    if (coverage) {
      const w = bitmap.width / coverage.columns;
      const h = bitmap.height / coverage.rows;
      ctx.lineWidth = line / 2;
      coverage.cells.forEach((row, r) =>
        row.forEach((count, c) => {
          ctx.fillStyle = count > 0 ? "rgba(40, 200, 90, 0.28)" : "rgba(240, 170, 20, 0.18)";
          ctx.fillRect(c * w, r * h, w, h);
          ctx.strokeStyle = "rgba(255, 255, 255, 0.5)";
          ctx.strokeRect(c * w, r * h, w, h);
        }),
      );
    }
    ctx.fillStyle = "#2ecc71";
    for (const [x, y] of this.overlay.points ?? []) {
      ctx.beginPath();
      ctx.arc(x, y, line * 1.5, 0, 2 * Math.PI);
      ctx.fill();
    }
    ctx.lineWidth = line;
    ctx.font = `${Math.round(line * 9)}px sans-serif`;
    for (const mark of this.overlay.boxes ?? []) {
      ctx.strokeStyle = mark.tone === "warn" ? "#f39c12" : "#2ecc71";
      ctx.strokeRect(mark.x, mark.y, mark.width, mark.height);
      if (mark.label) {
        ctx.fillStyle = ctx.strokeStyle;
        ctx.fillText(mark.label, mark.x, Math.max(line * 9, mark.y - line * 2));
      }
    }
    const box = this.drag ? this.dragBox() : this.drawing ? this.drawn : null;
    if (box) {
      ctx.setLineDash([line * 4, line * 3]);
      ctx.strokeStyle = "#3ea6ff";
      ctx.strokeRect(box.x, box.y, box.width, box.height);
      ctx.setLineDash([]);
    }
  }

  /** Where a pointer is on the image (px), the picture fitted into the canvas's box. */
  private toImage(event: PointerEvent): [number, number] | null {
    const canvas = this.canvas;
    if (!canvas || !this.size) return null;
    const [width, height] = this.size;
    const rect = canvas.getBoundingClientRect();
    const scale = Math.min(rect.width / width, rect.height / height);
    const left = rect.left + (rect.width - width * scale) / 2;
    const top = rect.top + (rect.height - height * scale) / 2;
    const x = Math.min(Math.max((event.clientX - left) / scale, 0), width);
    const y = Math.min(Math.max((event.clientY - top) / scale, 0), height);
    return [x, y];
  }

  private dragBox(): Box {
    const d = this.drag!;
    const x = Math.round(Math.min(d.x0, d.x1));
    const y = Math.round(Math.min(d.y0, d.y1));
    return {
      x,
      y,
      width: Math.round(Math.max(d.x0, d.x1)) - x,
      height: Math.round(Math.max(d.y0, d.y1)) - y,
    };
  }

  private onDown(event: PointerEvent): void {
    if (!this.drawing || this.drag) return;
    const at = this.toImage(event);
    if (!at) return;
    event.preventDefault();
    (event.target as Element).setPointerCapture(event.pointerId);
    this.drag = { x0: at[0], y0: at[1], x1: at[0], y1: at[1], pointer: event.pointerId };
  }

  private onMove(event: PointerEvent): void {
    if (!this.drag || event.pointerId !== this.drag.pointer) return;
    const at = this.toImage(event);
    if (!at) return;
    [this.drag.x1, this.drag.y1] = at;
    this.paint();
  }

  private onUp(event: PointerEvent): void {
    if (!this.drag || event.pointerId !== this.drag.pointer) return;
    this.onMove(event);
    const box = this.dragBox();
    this.drag = null;
    if (event.type === "pointerup" && box.width >= MIN_BOX && box.height >= MIN_BOX) {
      this.drawn = box;
      this.dispatchEvent(new CustomEvent<Box>("box", { detail: box, bubbles: true, composed: true }));
    }
    this.paint();
  }

  render() {
    const aspect = this.size ? `${this.size[0]} / ${this.size[1]}` : "16 / 10";
    return html`
      <canvas
        data-testid="camera-canvas"
        class=${this.drawing ? "drawing" : ""}
        style="--aspect: ${aspect}"
        aria-label=${t("vision.view.label", { camera: this.camera })}
        @pointerdown=${this.onDown}
        @pointermove=${this.onMove}
        @pointerup=${this.onUp}
        @pointercancel=${this.onUp}
      ></canvas>
      ${this.problem
        ? html`<p class="problem" role="status" data-testid="camera-problem">${this.problem}</p>`
        : ""}
    `;
  }
}

customElements.define("op-camera-view", OpCameraView);
