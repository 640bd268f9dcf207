import { html } from "lit";
import { client, errorText, ok, type Schemas } from "../api";
import { t } from "../i18n";
import { quaternionToRpy, rpyToQuaternion } from "../math";
import { makes, request } from "../rights";
import { shared } from "../styles";
import { lengthWithUnit } from "../units";
import { lengthField, numberField } from "./fields";
import {
  type OperationStatus,
  asKind,
  cancelOperation,
  follow,
  operationView,
  saveOperation,
  savesOperation,
} from "./operation";
import { VisionStep } from "./step";
import { visionStyles } from "./styles";

// The camera's pose in the world, from the calibration board lying at a known pose: typed
// (the board's first corner and its turn; face up on the table is roll 180°) or a stored
// frame or pose. Saved as `frames.<camera>`.

type Placement = Schemas["ExtrinsicResult"];

export class OpPlacementTab extends VisionStep {
  static properties = {
    camera: { type: String },
    typed: { state: true },
    variable: { state: true },
    variables: { state: true },
    frames: { state: true },
    op: { state: true },
    saved: { state: true },
  };
  declare camera: string;
  declare typed: { x: number; y: number; z: number; roll: number; pitch: number; yaw: number };
  declare variable: string;
  declare variables: string[];
  declare frames: number;
  declare op: OperationStatus<Placement> | null;
  declare saved: string;

  static styles = [shared, visionStyles];

  constructor() {
    super();
    this.camera = "";
    this.typed = { x: 0, y: 0, z: 0, roll: 180, pitch: 0, yaw: 0 };
    this.variable = "";
    this.variables = [];
    this.frames = 3;
    this.op = null;
    this.saved = "";
  }

  connectedCallback(): void {
    super.connectedCallback();
    void this.loadVariables();
  }

  protected willUpdate(changed: Map<string, unknown>): void {
    // Another camera: what was found for the last one is not this one's.
    if (changed.has("camera") && changed.get("camera") !== undefined) {
      this.op = null;
      this.saved = "";
    }
  }

  private async loadVariables(): Promise<void> {
    try {
      const all = await ok(client.GET("/api/variables"));
      this.variables = all
        .filter((v) => (v.type === "frame" || v.type === "pose") && !v.name.startsWith("frames."))
        .map((v) => v.name)
        .sort();
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private run(): Promise<void> {
    return this.act(async () => {
      this.saved = "";
      const p = this.typed;
      const body: Schemas["ExtrinsicRequest"] = { camera: this.camera, frames: this.frames };
      if (this.variable) body.board_variable = this.variable;
      else body.board_pose = { position: [p.x, p.y, p.z], orientation: rpyToQuaternion(p.roll, p.pitch, p.yaw) };
      const started = asKind<Placement>(
        await ok(client.POST("/api/vision/extrinsic", { body })));
      const camera = this.camera;
      await follow(started, (s) => (this.op = s), () => this.camera === camera && this.isConnected);
    });
  }

  private async save(): Promise<void> {
    try {
      this.saved = (await saveOperation(this.op!.id)).join(", ");
      this.dispatchEvent(new CustomEvent("placed", { bubbles: true, composed: true }));
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private set(field: keyof OpPlacementTab["typed"], value: number): void {
    this.typed = { ...this.typed, [field]: value };
  }

  private result() {
    const r = this.op?.state === "done" ? this.op.result : null;
    if (!r) return "";
    const [x, y, z] = r.pose.position;
    const [roll, pitch, yaw] = quaternionToRpy(r.pose.orientation);
    return html`<section data-testid="placement-result">
      <h3>${t("vision.result")}</h3>
      <dl class="quality">
        <dt>${t("vision.placement.position")}</dt>
        <dd>${lengthWithUnit(x)}, ${lengthWithUnit(y)}, ${lengthWithUnit(z)}</dd>
        <dt>${t("vision.placement.turn")}</dt>
        <dd>${roll.toFixed(2)}°, ${pitch.toFixed(2)}°, ${yaw.toFixed(2)}°</dd>
        <dt>${t("vision.placement.reprojection")}</dt>
        <dd>${r.reprojection.toFixed(3)} px</dd>
        <dt>${t("vision.placement.spread")}</dt>
        <dd data-testid="placement-spread">${lengthWithUnit(r.spread_mm / 1000)}, ${r.spread_deg.toFixed(3)}°</dd>
      </dl>
      <div class="actions">
        <button class="primary" data-testid="placement-save"
          ?disabled=${this.saved !== ""} ${savesOperation(this.op!.id)}
          @click=${() => void this.save()}>${t("vision.save")}</button>
      </div>
      ${this.saved ? html`<p class="chip ok" data-testid="placement-saved">${t("vision.saved", { names: this.saved })}</p>` : ""}
    </section>`;
  }

  render() {
    const p = this.typed;
    const running = this.op?.state === "running";
    return html`
      <p class="muted">${t("vision.placement.intro")}</p>
      <div class="fields">
        <label>${t("vision.placement.board_at")}
          <select data-testid="placement-variable" .value=${this.variable}
            @change=${(e: Event) => (this.variable = (e.target as HTMLSelectElement).value)}>
            <option value="">${t("vision.placement.typed")}</option>
            ${this.variables.map((v) => html`<option value=${v} ?selected=${v === this.variable}>${v}</option>`)}
          </select></label>
        ${numberField(t("vision.placement.frames"), "placement-frames", this.frames, (v) => (this.frames = Math.round(v)), "1")}
      </div>
      ${this.variable
        ? ""
        : html`<div class="fields">
            ${lengthField("vision.x", "board-x", p.x, (v) => this.set("x", v))}
            ${lengthField("vision.y", "board-y", p.y, (v) => this.set("y", v))}
            ${lengthField("vision.z", "board-z", p.z, (v) => this.set("z", v))}
            ${numberField(`${t("vision.roll")} (°)`, "board-roll", p.roll, (v) => this.set("roll", v))}
            ${numberField(`${t("vision.pitch")} (°)`, "board-pitch", p.pitch, (v) => this.set("pitch", v))}
            ${numberField(`${t("vision.yaw")} (°)`, "board-yaw", p.yaw, (v) => this.set("yaw", v))}
          </div>`}
      <div class="actions">
        <button class="primary" data-testid="placement-run"
          ?disabled=${this.busy || running || !this.camera}
          ${makes(request("POST", "/api/vision/extrinsic"))}
          @click=${() => void this.run()}>${t("vision.placement.run")}</button>
      </div>
      ${operationView(this.op, () => void cancelOperation(this.op!.id).catch((e) => (this.error = errorText(e))))}
      ${this.result()}
      ${this.error ? html`<p class="error" role="alert" data-testid="placement-error">${this.error}</p>` : ""}
    `;
  }
}

customElements.define("op-placement-tab", OpPlacementTab);
