import { html } from "lit";
import { client, errorText, ok, type Schemas } from "../api";
import { control, leaseRequest } from "../control";
import { t } from "../i18n";
import { Listening } from "../listening";
import { feed } from "../live";
import { makes, request } from "../rights";
import { shared } from "../styles";
import { lengthWithUnit } from "../units";
import { DICTIONARIES } from "./intrinsic-tab";
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

// Where a robot stands in the world: it visits poses generated in a box of its base frame
// (each collision-checked by the motion service) with the tag on its flange turned towards
// the camera, which finds the tag at each. The run moves the robot under this tablet's
// control of it; Cancel stops it. Saved as `frames.<robot>`.

type OriginResult = Schemas["RobotOriginResult"];

// The run going on, kept beyond this element: the panel is made anew each time it is shown,
// and a run that moves the robot must still show its progress and Cancel when it is back.
let running: OperationStatus<OriginResult> | null = null;

interface Region {
  centre: [number, number, number];
  size: [number, number, number];
  tilt: number;
  spin: number;
}

export class OpOriginTab extends VisionStep {
  static properties = {
    camera: { type: String },
    robot: { state: true },
    region: { state: true },
    poses: { state: true },
    speed: { state: true },
    tag: { state: true },
    op: { state: true },
    saved: { state: true },
  };
  declare camera: string;
  declare robot: string;
  declare region: Region;
  declare poses: number;
  declare speed: number;
  declare tag: { id: number; size: number; dictionary: string };
  declare op: OperationStatus<OriginResult> | null;
  declare saved: string;
  private readonly onControl = () => this.requestUpdate();

  static styles = [shared, visionStyles];

  constructor() {
    super();
    new Listening(this, control, "change", this.onControl);
    this.camera = "";
    this.robot = "";
    this.region = { centre: [0.4, 0, 0.4], size: [0.3, 0.3, 0.2], tilt: 30, spin: 60 };
    this.poses = 12;
    this.speed = 50;
    this.tag = { id: 0, size: 0.06, dictionary: "4x4_50" };
    this.op = null;
    this.saved = "";
  }

  connectedCallback(): void {
    super.connectedCallback();
    if (running !== null && this.op === null) void this.watch(running);
  }

  private async watch(started: OperationStatus<OriginResult>): Promise<void> {
    const ended = await follow(
      started,
      (s) => {
        this.op = s;
        running = s.state === "running" ? s : null;
      },
      () => this.isConnected,
    );
    if (ended.state !== "running") running = null;
  }

  private robots(): string[] {
    return feed.devices.filter((d) => d.kind === "robot").map((d) => d.local_name);
  }

  private run(robot: string): Promise<void> {
    return this.act(async () => {
      this.saved = "";
      const token = control.token(robot);
      const body = {
        robot,
        camera: this.camera,
        tag: this.tag,
        region: this.region,
        poses: this.poses,
        speed: this.speed / 100,
      };
      const started = asKind<OriginResult>(await ok(client.POST("/api/vision/robot_origin",
        { params: { header: { "X-Lease-Token": token } }, body })));
      await this.watch(started);
    });
  }

  private setRegion(part: "centre" | "size", axis: number, metres: number): void {
    const values = [...this.region[part]] as [number, number, number];
    values[axis] = metres;
    this.region = { ...this.region, [part]: values };
  }

  private result() {
    const r = this.op?.state === "done" ? this.op.result : null;
    if (!r) return "";
    const [x, y, z] = r.base.position;
    return html`<section data-testid="origin-result">
      <h3>${t("vision.result")}</h3>
      <dl class="quality">
        <dt>${t("vision.origin.base")}</dt>
        <dd>${lengthWithUnit(x)}, ${lengthWithUnit(y)}, ${lengthWithUnit(z)}</dd>
        <dt>${t("vision.origin.moved")}</dt>
        <dd data-testid="origin-moved">${lengthWithUnit(r.moved_mm / 1000)}, ${r.moved_deg.toFixed(3)}°</dd>
        <dt>${t("vision.origin.rms")}</dt>
        <dd>${r.rms_px.toFixed(3)} px</dd>
      </dl>
      <ul class="rows" data-testid="origin-pose-list">
        ${r.poses.map(
          (p) => html`<li data-outlier=${p.outlier}>
            <span>#${p.index + 1}</span>
            <span>${p.seen
              ? `${p.residual_px?.toFixed(2) ?? "–"} px · ${p.residual_mm === null ? "–" : lengthWithUnit(p.residual_mm / 1000)}`
              : p.reason}${p.outlier ? ` · ${t("vision.intrinsic.left_out")}` : ""}</span>
          </li>`,
        )}
      </ul>
      <div class="actions">
        <button class="primary" data-testid="origin-save" ?disabled=${this.saved !== ""}
          ${savesOperation(this.op!.id)}
          @click=${() => void this.act(async () => {
            this.saved = (await saveOperation(this.op!.id)).join(", ");
          })}>${t("vision.save")}</button>
      </div>
      ${this.saved ? html`<p class="chip ok" data-testid="origin-saved">${t("vision.saved", { names: this.saved })}</p>` : ""}
    </section>`;
  }

  render() {
    const robots = this.robots();
    const robot = robots.includes(this.robot) ? this.robot : (robots[0] ?? "");
    const mine = robot !== "" && control.holds(robot);
    const running = this.op?.state === "running";
    const r = this.region;
    const axes = ["x", "y", "z"] as const;
    return html`
      <p class="muted">${t("vision.origin.intro")}</p>
      <div class="fields">
        <label>${t("vision.origin.robot")}
          <select data-testid="origin-robot" .value=${robot}
            @change=${(e: Event) => (this.robot = (e.target as HTMLSelectElement).value)}>
            ${robots.map((name) => html`<option value=${name} ?selected=${name === robot}>${name}</option>`)}
          </select></label>
        ${numberField(t("vision.origin.poses"), "origin-poses", this.poses, (v) => (this.poses = Math.round(v)), "1")}
        ${numberField(t("vision.origin.speed"), "origin-speed", this.speed, (v) => (this.speed = v), "1")}
      </div>
      <h3>${t("vision.origin.region")}</h3>
      <div class="fields">
        ${axes.map((a, i) => lengthField(`vision.origin.centre_${a}`, `origin-centre-${a}`, r.centre[i], (v) => this.setRegion("centre", i, v)))}
        ${axes.map((a, i) => lengthField(`vision.origin.size_${a}`, `origin-size-${a}`, r.size[i], (v) => this.setRegion("size", i, v)))}
        ${numberField(t("vision.origin.tilt"), "origin-tilt", r.tilt, (v) => (this.region = { ...r, tilt: v }))}
        ${numberField(t("vision.origin.spin"), "origin-spin", r.spin, (v) => (this.region = { ...r, spin: v }))}
      </div>
      <h3>${t("vision.origin.tag")}</h3>
      <div class="fields">
        ${numberField(t("vision.origin.tag_id"), "origin-tag-id", this.tag.id, (v) => (this.tag = { ...this.tag, id: Math.round(v) }), "1")}
        ${lengthField("vision.origin.tag_size", "origin-tag-size", this.tag.size, (v) => (this.tag = { ...this.tag, size: v }))}
        <label>${t("vision.board.dictionary")}
          <select .value=${this.tag.dictionary}
            @change=${(e: Event) => (this.tag = { ...this.tag, dictionary: (e.target as HTMLSelectElement).value })}>
            ${DICTIONARIES.map((d) => html`<option value=${d} ?selected=${d === this.tag.dictionary}>${d}</option>`)}
          </select></label>
      </div>
      <div class="actions">
        ${mine
          ? ""
          : html`<button data-testid="origin-control" ?disabled=${!robot}
              ${makes(...(robot ? [leaseRequest(robot)] : []))}
              @click=${() => void this.act(() => control.take(robot))}>${t("jog.control.take")}</button>`}
        <button class="primary" data-testid="origin-run"
          ?disabled=${this.busy || running || !mine || !this.camera}
          ${makes(request("POST", "/api/vision/robot_origin"))}
          @click=${() => void this.run(robot)}>${t("vision.origin.run")}</button>
      </div>
      ${robots.length ? "" : html`<p class="muted">${t("vision.origin.no_robot")}</p>`}
      ${operationView(this.op, () => void cancelOperation(this.op!.id).catch((e) => (this.error = errorText(e))))}
      ${this.result()}
      ${this.error ? html`<p class="error" role="alert" data-testid="origin-error">${this.error}</p>` : ""}
    `;
  }
}

customElements.define("op-origin-tab", OpOriginTab);
