import { LitElement, css, html } from "lit";
import { api, errorText } from "../api";
import { control } from "../control";
import { quaternionToRpy, rpyToQuaternion } from "../math";
import { shared } from "../styles";
import type { Pose } from "../types";

// The tool a robot carries: where its tool centre point is on the flange and what the
// payload weighs. Jogging, moves and waypoints use this TCP; the robot gets it again
// whenever it connects. Changing it needs control of the robot, which halts first.

interface Payload {
  mass: number;
  center_of_mass: number[];
}

interface ToolInfo {
  tcp: Pose;
  payload: Payload;
  max_payload: number | null;
}

interface Draft {
  x: number;
  y: number;
  z: number;
  roll: number;
  pitch: number;
  yaw: number;
  mass: number;
  cx: number;
  cy: number;
  cz: number;
}

const FIELDS: [keyof Draft, string, number][] = [
  ["x", "TCP X mm", 1],
  ["y", "TCP Y mm", 1],
  ["z", "TCP Z mm", 1],
  ["roll", "TCP roll °", 1],
  ["pitch", "TCP pitch °", 1],
  ["yaw", "TCP yaw °", 1],
  ["mass", "Payload kg", 0.1],
  ["cx", "Centre of mass X mm", 1],
  ["cy", "Centre of mass Y mm", 1],
  ["cz", "Centre of mass Z mm", 1],
];

const round = (v: number) => Math.round(v * 10) / 10;

function draftOf(info: ToolInfo): Draft {
  const [roll, pitch, yaw] = quaternionToRpy(info.tcp.orientation);
  const [x, y, z] = info.tcp.position;
  const [cx, cy, cz] = info.payload.center_of_mass;
  return { x: round(x * 1000), y: round(y * 1000), z: round(z * 1000), roll: round(roll),
    pitch: round(pitch), yaw: round(yaw), mass: round(info.payload.mass),
    cx: round(cx * 1000), cy: round(cy * 1000), cz: round(cz * 1000) };
}

export class OpToolCard extends LitElement {
  static properties = {
    robot: { type: String },
    draft: { state: true },
    rated: { state: true },
    message: { state: true },
    saved: { state: true },
  };
  declare robot: string;
  declare draft: Draft | null;
  declare rated: number | null;
  declare message: string;
  declare saved: string;
  private loaded = "";

  static styles = [
    shared,
    css`
      .fields {
        display: grid;
        grid-template-columns: repeat(3, minmax(0, 1fr));
        gap: 8px;
        margin-bottom: 10px;
      }
      label {
        display: flex;
        flex-direction: column;
        gap: 4px;
        font-size: 15px;
      }
      input {
        width: 100%;
      }
      .row {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
        align-items: center;
      }
    `,
  ];

  constructor() {
    super();
    this.robot = "";
    this.draft = null;
    this.rated = null;
    this.message = "";
    this.saved = "";
  }

  connectedCallback(): void {
    super.connectedCallback();
    control.addEventListener("change", this.onControl);
  }

  disconnectedCallback(): void {
    control.removeEventListener("change", this.onControl);
    this.loaded = "";
    super.disconnectedCallback();
  }

  private readonly onControl = () => this.requestUpdate();

  protected updated(): void {
    if (this.robot && this.robot !== this.loaded) void this.load();
  }

  private async load(): Promise<void> {
    const robot = this.robot;
    this.loaded = robot;
    this.draft = null;
    try {
      const details = await api<{ info: { info: ToolInfo } | null }>(
        "GET", `/api/devices/${encodeURIComponent(robot)}`);
      if (robot !== this.robot) return;
      if (!details.info) {
        this.message = `${robot} is not connected: its tool shows once it is.`;
        this.loaded = ""; // try again on the next update
        return;
      }
      this.draft = draftOf(details.info.info);
      this.rated = details.info.info.max_payload;
      this.message = "";
    } catch (err) {
      this.loaded = "";
      this.message = errorText(err);
    }
  }

  private async save(): Promise<void> {
    const d = this.draft;
    if (!d) return;
    if (!Object.values(d).every(Number.isFinite)) {
      this.message = "Every tool value must be a number.";
      return;
    }
    const setup = {
      tcp: { position: [d.x / 1000, d.y / 1000, d.z / 1000],
        orientation: rpyToQuaternion(d.roll, d.pitch, d.yaw) },
      payload: { mass: d.mass, center_of_mass: [d.cx / 1000, d.cy / 1000, d.cz / 1000] },
    };
    try {
      const info = await api<ToolInfo>("PUT", `/api/devices/${encodeURIComponent(this.robot)}/tool`,
        setup, { "X-Lease-Token": control.token(this.robot) ?? "" });
      this.draft = draftOf(info);
      this.message = "";
      this.saved = "Saved: jogging, moves and pose waypoints use this TCP now.";
    } catch (err) {
      this.saved = "";
      this.message = errorText(err);
    }
  }

  render() {
    const d = this.draft;
    const mine = control.holds(this.robot);
    return html`
      ${this.message ? html`<p class="error" role="alert" data-testid="tool-message">${this.message}</p>` : ""}
      ${d ? html`<div class="fields" data-testid="tool-editor">
          ${FIELDS.map(([key, label, step]) => html`<label>
            <span>${label}</span>
            <input type="number" inputmode="decimal" step=${step} data-testid="tool-${key}"
              .value=${String(d[key])}
              @change=${(e: Event) => {
                this.saved = "";
                this.draft = { ...d, [key]: Number((e.target as HTMLInputElement).value) };
              }} /></label>`)}
        </div>
        <div class="row">
          <button class="primary" data-testid="save-tool" ?disabled=${!mine}
            @click=${() => this.save()}>Save tool</button>
          <span class="muted">${mine
            ? `The TCP is on the flange (its Z points out of it).${this.rated ? ` Rated payload ${this.rated} kg.` : ""} The robot halts when the tool changes.`
            : "Take control of the robot (Jog panel) to change its tool."}</span>
        </div>
        ${this.saved ? html`<p class="chip ok" data-testid="tool-saved">${this.saved}</p>` : ""}`
        : this.message ? "" : html`<p class="muted">Loading…</p>`}`;
  }
}

customElements.define("op-tool-card", OpToolCard);
