import { LitElement, css, html } from "lit";
import { client, errorText, ok } from "../api";
import { control } from "../control";
import { type StringKey, t } from "../i18n";
import { Listening } from "../listening";
import { quaternionToRpy, rpyToQuaternion } from "../math";
import { makes, request } from "../rights";
import { shared } from "../styles";
import type { RobotDetails, RobotInfo } from "../types";
import {
  ANGLE_FIELD,
  asShown,
  degrees,
  type FieldScale,
  LENGTH_FIELD,
  radians,
} from "../units";

// The tool a robot carries: where its tool centre point is on the flange and what the
// payload weighs. Jogging, moves and waypoints use this TCP; the robot gets it again
// whenever it connects. Changing it needs control of the robot, which halts first.

type ToolInfo = Pick<RobotInfo, "tcp" | "payload" | "max_payload">;

/** The tool as edited: metres, radians and kilograms. */
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

type Measure = "length" | "angle" | "mass";

const FIELDS: [keyof Draft, StringKey, Measure][] = [
  ["x", "scene.tool.tcp_x", "length"],
  ["y", "scene.tool.tcp_y", "length"],
  ["z", "scene.tool.tcp_z", "length"],
  ["roll", "scene.tool.tcp_roll", "angle"],
  ["pitch", "scene.tool.tcp_pitch", "angle"],
  ["yaw", "scene.tool.tcp_yaw", "angle"],
  ["mass", "scene.tool.payload", "mass"],
  ["cx", "scene.tool.com_x", "length"],
  ["cy", "scene.tool.com_y", "length"],
  ["cz", "scene.tool.com_z", "length"],
];

const round = (v: number) => Math.round(v * 10) / 10;
const KILOGRAMS: FieldScale = {
  unit: () => "kg",
  step: () => 0.1,
  toField: (v) => v,
  fromField: (v) => v,
};
const MEASURES: Record<Measure, FieldScale> = {
  length: LENGTH_FIELD,
  angle: ANGLE_FIELD,
  mass: KILOGRAMS,
};

function draftOf(info: ToolInfo): Draft {
  const [roll, pitch, yaw] = quaternionToRpy(info.tcp.orientation).map(radians);
  const [x, y, z] = info.tcp.position;
  const [cx, cy, cz] = info.payload.center_of_mass;
  const l = (v: number) => asShown(LENGTH_FIELD, v);
  const a = (v: number) => asShown(ANGLE_FIELD, v);
  return { x: l(x), y: l(y), z: l(z), roll: a(roll), pitch: a(pitch), yaw: a(yaw),
    mass: round(info.payload.mass), cx: l(cx), cy: l(cy), cz: l(cz) };
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
    new Listening(this, control, "change", this.onControl);
    this.robot = "";
    this.draft = null;
    this.rated = null;
    this.message = "";
    this.saved = "";
  }

  disconnectedCallback(): void {
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
      // A robot's: its driver's info is the robot kind's.
      const details = (await ok(client.GET("/api/devices/{local_name}",
        { params: { path: { local_name: robot } } }))) as RobotDetails;
      if (robot !== this.robot) return;
      if (!details.info) {
        this.message = t("scene.tool.not_connected", { robot });
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
      this.message = t("scene.tool.not_a_number");
      return;
    }
    const setup = {
      tcp: { position: [d.x, d.y, d.z],
        orientation: rpyToQuaternion(degrees(d.roll), degrees(d.pitch), degrees(d.yaw)) },
      payload: { mass: d.mass, center_of_mass: [d.cx, d.cy, d.cz] },
    };
    try {
      const info = await ok(client.PUT("/api/devices/{local_name}/tool", {
        params: { path: { local_name: this.robot },
          header: { "X-Lease-Token": control.token(this.robot) ?? "" } },
        body: setup,
      }));
      this.draft = draftOf(info);
      this.message = "";
      this.saved = t("scene.tool.saved");
    } catch (err) {
      this.saved = "";
      this.message = errorText(err);
    }
  }

  render() {
    const d = this.draft;
    const mine = control.holds(this.robot);
    let hint = t("scene.tool.take_control");
    if (mine && this.rated) hint = t("scene.tool.hint_rated", { mass: this.rated });
    else if (mine) hint = t("scene.tool.hint");
    return html`
      ${this.message ? html`<p class="error" role="alert" data-testid="tool-message">${this.message}</p>` : ""}
      ${d ? html`<div class="fields" data-testid="tool-editor">
          ${FIELDS.map(([key, label, measure]) => html`<label>
            <span>${t(label, { unit: MEASURES[measure].unit() })}</span>
            <input type="number" inputmode="decimal" step=${MEASURES[measure].step()}
              data-testid="tool-${key}" .value=${String(MEASURES[measure].toField(d[key]))}
              @change=${(e: Event) => {
                const value = Number((e.target as HTMLInputElement).value);
                this.saved = "";
                this.draft = { ...d, [key]: MEASURES[measure].fromField(value) };
              }} /></label>`)}
        </div>
        <div class="row">
          <button class="primary" data-testid="save-tool" ?disabled=${!mine}
            ${makes(request("PUT", `/api/devices/${encodeURIComponent(this.robot)}/tool`))}
            @click=${() => this.save()}>${t("scene.tool.save")}</button>
          <span class="muted">${hint}</span>
        </div>
        ${this.saved ? html`<p class="chip ok" data-testid="tool-saved">${this.saved}</p>` : ""}`
        : this.message ? "" : html`<p class="muted">${t("scene.loading")}</p>`}`;
  }
}

customElements.define("op-tool-card", OpToolCard);
