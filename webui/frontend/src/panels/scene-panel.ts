import { LitElement, type TemplateResult, css, html } from "lit";
import { client, errorText, ok, type Schemas } from "../api";
import { FocusController, focus } from "../focus";
import { type StringKey, t } from "../i18n";
import { worded } from "../i18n/words";
import { FeedController, feed } from "../live";
import { quaternionToRpy, rpyToQuaternion } from "../math";
import { makes, request } from "../rights";
import { RobotLoader } from "../robot-loader";
import { shared } from "../styles";
import {
  ANGLE_FIELD,
  angleFieldStep,
  angleUnit,
  asShown,
  degrees,
  type FieldScale,
  LENGTH_FIELD,
  lengthFromField,
  lengthToField,
  lengthUnit,
  radians,
  units,
} from "../units";
import type { Obstacle, PathPreview, PoseJson, WorldContents } from "../three/scene";
import "../components/clearance-chip";
import "../components/robot-view";
import "../components/tool-card";
import type { RobotModel } from "../components/robot-view";
import type { Waypoint } from "../components/waypoint-list";

type SceneObject = Omit<Obstacle, "name" | "selected">;

/** Where a robot's base stands in the world, as edited: metres and radians. */
interface Mount {
  x: number;
  y: number;
  z: number;
  roll: number;
  pitch: number;
  yaw: number;
}

type Measure = "length" | "angle";

// X, Y and Z read the same in every language; only their unit follows the choice.
const MOUNT_FIELDS: [keyof Mount, Measure, () => TemplateResult | string][] = [
  ["x", "length", () => html`X ${lengthUnit()}`],
  ["y", "length", () => html`Y ${lengthUnit()}`],
  ["z", "length", () => html`Z ${lengthUnit()}`],
  ["roll", "angle", () => t("scene.mount.roll", { unit: angleUnit() })],
  ["pitch", "angle", () => t("scene.mount.pitch", { unit: angleUnit() })],
  ["yaw", "angle", () => t("scene.mount.yaw", { unit: angleUnit() })],
];

const SCALE: Record<Measure, FieldScale> = { length: LENGTH_FIELD, angle: ANGLE_FIELD };

function mountOf(base: PoseJson | null): Mount {
  const [x, y, z] = base?.position ?? [0, 0, 0];
  const [roll, pitch, yaw] = quaternionToRpy(base?.orientation ?? [0, 0, 0, 1]).map(radians);
  const l = (v: number) => asShown(LENGTH_FIELD, v);
  const a = (v: number) => asShown(ANGLE_FIELD, v);
  return { x: l(x), y: l(y), z: l(z), roll: a(roll), pitch: a(pitch), yaw: a(yaw) };
}

type PlanReport = Schemas["PlanReport"];

/** A tap's nudge, and the step of the length fields: 10 mm, or a round 0.5 in. */
const nudgeStep = (): number => (units.length === "mm" ? 10 : 0.5);
/** Positions and sizes show whole millimetres; inches as finely as units.ts rounds them. */
const sizeField = (metres: number): number =>
  units.length === "mm" ? Math.round(metres * 1000) : lengthToField(metres);
const AXES = ["x", "y", "z"] as const;

/** A new object's name: its shape and the first number no variable has. */
function freeName(shape: string, taken: Set<string>): string {
  let n = 1;
  while (taken.has(`${shape}_${n}`)) n += 1;
  return `${shape}_${n}`;
}
// Per shape, each size's short name and its field's full label.
const SIZE_LABELS: Record<string, [StringKey, StringKey][]> = {
  box: [
    ["scene.size.length", "scene.size.length_x"],
    ["scene.size.width", "scene.size.width_y"],
    ["scene.size.height", "scene.size.height_z"],
  ],
  cylinder: [
    ["scene.size.radius", "scene.size.radius_label"],
    ["scene.size.height", "scene.size.height_label"],
  ],
  sphere: [["scene.size.radius", "scene.size.radius_label"]],
  mesh: [
    ["scene.size.scale", "scene.size.scale_x"],
    ["scene.size.scale", "scene.size.scale_y"],
    ["scene.size.scale", "scene.size.scale_z"],
  ],
};
const SHAPES: Record<string, StringKey> = {
  box: "scene.shape.box",
  cylinder: "scene.shape.cylinder",
  sphere: "scene.shape.sphere",
  mesh: "scene.shape.mesh",
};

// The collision scene: obstacles and keep-out zones in the 3D view, added, moved and deleted
// by touch, and the path a move would take previewed before it runs (red when it collides).
export class OpScenePanel extends LitElement {
  static properties = {
    robot: { state: true },
    model: { state: true },
    objects: { state: true },
    base: { state: true },
    selected: { state: true },
    draft: { state: true },
    waypoints: { state: true },
    target: { state: true },
    kind: { state: true },
    around: { state: true },
    preview: { state: true },
    previewing: { state: true },
    message: { state: true },
    confirmDelete: { state: true },
    mount: { state: true },
  };
  declare robot: string;
  declare model: RobotModel | null;
  declare objects: Record<string, SceneObject>;
  declare base: PoseJson | null;
  declare selected: string;
  declare draft: SceneObject | null;
  declare mount: Mount | null; // where the robot in focus stands, as edited
  declare waypoints: Waypoint[];
  declare target: string;
  declare kind: "joint" | "linear";
  declare around: boolean;
  declare preview: PlanReport | null;
  declare previewing: boolean;
  declare message: string;
  private loadError = "";
  declare confirmDelete: boolean;

  static styles = [
    shared,
    css`
      .layout {
        display: grid;
        grid-template-columns: minmax(0, 1.3fr) minmax(320px, 1fr);
        gap: 14px;
        /* The view stays in sight while the side column scrolls on its own. */
        height: calc(100dvh - 110px);
      }
      .view {
        display: flex;
        flex-direction: column;
        min-height: 0;
      }
      op-robot-view {
        flex: 1;
      }
      .side {
        display: flex;
        flex-direction: column;
        gap: 12px;
        overflow: auto;
        min-height: 0;
      }
      .row {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
        align-items: center;
      }
      .objects button {
        width: 100%;
        text-align: left;
        margin-bottom: 6px;
      }
      .objects button[aria-pressed="true"] {
        border-color: var(--accent);
        color: var(--accent);
      }
      .mount {
        display: grid;
        grid-template-columns: repeat(3, minmax(0, 1fr));
        gap: 8px;
        margin-bottom: 10px;
      }
      .mount label {
        display: flex;
        flex-direction: column;
        gap: 4px;
        font-size: 15px;
      }
      .mount input {
        width: 100%;
      }
      .grid {
        display: grid;
        grid-template-columns: 72px 1fr 64px 64px;
        gap: 6px;
        align-items: center;
      }
      select {
        min-height: var(--touch);
        border-radius: 10px;
        border: 2px solid var(--line);
        background: var(--bg);
        color: var(--text);
        font: inherit;
        padding: 0 10px;
      }
      label.check {
        display: flex;
        gap: 8px;
        align-items: center;
        min-height: var(--touch);
      }
      label.check input {
        width: 28px;
        min-height: 28px;
      }
      .chip.bad {
        color: var(--bad);
      }
      h2 {
        margin: 0 0 8px;
      }
      @media (max-width: 900px) {
        .layout {
          grid-template-columns: 1fr;
          height: auto;
        }
        op-robot-view {
          flex: none;
          height: 320px;
        }
        .side {
          overflow: visible;
        }
      }
    `,
  ];

  constructor() {
    super();
    new FeedController(this);
    new FocusController(this);
    new RobotLoader(this, (robot) => this.loadRobot(robot));
    this.robot = "";
    this.model = null;
    this.objects = {};
    this.base = null;
    this.selected = "";
    this.draft = null;
    this.waypoints = [];
    this.target = "";
    this.kind = "joint";
    this.around = false;
    this.preview = null;
    this.previewing = false;
    this.message = "";
    this.confirmDelete = false;
    this.mount = null;
  }

  protected willUpdate(): void {
    this.robot = focus.robot;
  }

  private async loadRobot(name: string): Promise<boolean> {
    const robot = { params: { path: { robot: name } } };
    if (this.model?.name !== name) this.model = null;
    try {
      const model = await ok(client.GET("/api/jog/robots/{robot}", robot));
      if (name !== this.robot) return true; // the focus moved on meanwhile
      this.model = model;
      this.waypoints = await ok(client.GET("/api/jog/robots/{robot}/waypoints", robot));
      await this.loadScene();
      if (this.message === this.loadError) this.message = "";
      this.loadError = "";
      return true;
    } catch (err) {
      this.loadError = this.message = errorText(err);
      return false;
    }
  }

  private async loadScene(): Promise<void> {
    const scene = await ok(client.GET("/api/motion/scene"));
    this.objects = scene.objects;
    this.base = scene.robots[this.robot]?.base ?? null;
    this.mount = mountOf(this.base);
    if (this.selected && !(this.selected in this.objects)) this.select("");
  }

  // Objects ---------------------------------------------------------------------------------

  private select(name: string): void {
    this.selected = name;
    this.draft = name ? structuredClone(this.objects[name]) : null;
    this.confirmDelete = false;
  }

  private async add(shape: "box" | "cylinder"): Promise<void> {
    let names: Set<string>;
    try {
      // Any variable's name is taken, not only scene objects': a new box must never
      // overwrite a waypoint.
      const all = await ok(client.GET("/api/variables"));
      names = new Set(all.map((v) => v.name));
    } catch (err) {
      this.message = errorText(err);
      return;
    }
    const name = freeName(shape, names);
    const object: SceneObject = {
      shape,
      size: shape === "box" ? [0.2, 0.2, 0.2] : [0.05, 0.4],
      pose: { position: [0.4, 0.0, shape === "box" ? 0.1 : 0.2], orientation: [0, 0, 0, 1] },
      keep_out: false,
      color: "#8a94a6",
      attached_to: null,
    };
    if (await this.save(name, object)) this.select(name);
  }

  private async save(name: string, object: SceneObject): Promise<boolean> {
    try {
      await ok(client.PUT("/api/variables/{name}", {
        params: { path: { name } },
        body: { type: "scene_object", value: object },
      }));
      this.message = "";
      await this.loadScene();
      await this.runPreview();
      return true;
    } catch (err) {
      this.message = errorText(err);
      return false;
    }
  }

  private async deleteSelected(): Promise<void> {
    if (!this.confirmDelete) {
      this.confirmDelete = true;
      return;
    }
    const name = this.selected;
    try {
      await ok(client.DELETE("/api/variables/{name}", { params: { path: { name } } }));
      this.select("");
      await this.loadScene();
      await this.runPreview();
    } catch (err) {
      this.message = errorText(err);
    }
  }

  private nudge(axis: number, delta: number): void {
    if (!this.draft) return;
    const draft = structuredClone(this.draft);
    draft.pose.position[axis] += delta;
    this.draft = draft;
    void this.save(this.selected, draft);
  }

  private edit(update: (draft: SceneObject, value: number) => void, e: Event): void {
    const value = lengthFromField(Number((e.target as HTMLInputElement).value));
    if (!this.draft || !Number.isFinite(value)) return;
    const draft = structuredClone(this.draft);
    update(draft, value);
    this.draft = draft;
  }

  // Mounting ---------------------------------------------------------------------------------

  /** Where the robot stands in the world: the frame the jog, motion and 3D view use. */
  private async saveMount(): Promise<void> {
    const m = this.mount;
    if (!m || !this.robot) return;
    if (!Object.values(m).every(Number.isFinite)) {
      this.message = t("scene.mount.not_a_number");
      return;
    }
    const pose = {
      position: [m.x, m.y, m.z],
      orientation: rpyToQuaternion(degrees(m.roll), degrees(m.pitch), degrees(m.yaw)),
    };
    try {
      await ok(client.PUT("/api/variables/{name}", {
        params: { path: { name: `frames.${this.robot}` } },
        body: { type: "frame", value: { pose } },
      }));
      this.message = "";
      await this.loadScene();
      await this.runPreview();
    } catch (err) {
      this.message = errorText(err);
    }
  }

  private mounting() {
    const m = this.mount;
    if (!m) return html`<p class="muted">${t("scene.loading")}</p>`;
    const steps = { length: nudgeStep(), angle: 10 * angleFieldStep() };
    return html`<div class="mount" data-testid="mount-editor">
        ${MOUNT_FIELDS.map(([key, measure, label]) => html`<label>
          <span>${label()}</span>
          <input type="number" inputmode="decimal" step=${steps[measure]}
            data-testid="mount-${key}" .value=${String(SCALE[measure].toField(m[key]))}
            @change=${(e: Event) => {
              const value = Number((e.target as HTMLInputElement).value);
              this.mount = { ...m, [key]: SCALE[measure].fromField(value) };
            }} /></label>`)}
      </div>
      <div class="row">
        <button class="primary" data-testid="save-mount" @click=${() => this.saveMount()}
          ${makes(request("PUT", `/api/variables/frames.${encodeURIComponent(this.robot)}`))}>
          ${t("scene.mount.save")}</button>
        <span class="muted">${t("scene.mount.hint", { robot: this.robot })}</span>
      </div>`;
  }

  // Path preview ----------------------------------------------------------------------------

  private async runPreview(): Promise<void> {
    if (!this.target || !this.robot) {
      this.preview = null;
      return;
    }
    this.previewing = true;
    try {
      this.preview = await ok(client.POST("/api/motion/robots/{robot}/plan", {
        params: { path: { robot: this.robot } },
        body: {
          kind: this.kind,
          target: { waypoint: this.target },
          avoid_obstacles: this.kind === "joint" && this.around,
        },
      }));
    } catch (err) {
      this.preview = { ok: false, code: "error", message: errorText(err), words: null,
                       duration: 0, planned_around: false, collision: null, tcp_path: [],
                       goal: [] };
    } finally {
      this.previewing = false;
    }
  }

  private world(): WorldContents {
    const obstacles = Object.entries(this.objects).map(([name, o]) => {
      const shown = name === this.selected && this.draft ? this.draft : o;
      return { ...shown, name, selected: name === this.selected };
    });
    let path: PathPreview | null = null;
    if (this.preview) {
      const hit = this.preview.collision?.position;
      path = {
        points: this.preview.tcp_path,
        ok: this.preview.ok,
        collision: hit ? [hit[0], hit[1], hit[2]] : null,
      };
    }
    return { obstacles, path };
  }

  // Rendering -------------------------------------------------------------------------------

  private previewChip() {
    const chip = (state: string, text: string, tone = "") =>
      html`<span class="chip ${tone}" data-testid="preview" data-state=${state}>${text}</span>`;
    if (this.previewing) return chip("busy", t("scene.preview.planning"));
    const p = this.preview;
    if (!p) return chip("none", t("scene.preview.none"));
    if (p.ok) return chip("ok", t("scene.preview.clear"), "ok");
    return chip(p.code === "collision" ? "collision" : "error", worded(p.message, p.words), "bad");
  }

  /** "box", or "box, keep-out". */
  private shapeText(o: SceneObject): string {
    const shape = o.shape in SHAPES ? t(SHAPES[o.shape]) : o.shape;
    return o.keep_out ? t("scene.objects.keep_out", { shape }) : shape;
  }

  private editor() {
    const d = this.draft;
    if (!d) return html`<p class="muted">${t("scene.editor.hint")}</p>`;
    const saves = makes(request("PUT", `/api/variables/${encodeURIComponent(this.selected)}`));
    const labels = SIZE_LABELS[d.shape] ?? [];
    const unit = lengthUnit();
    const step = nudgeStep();
    const nudge = lengthFromField(step);
    return html`
      <div class="grid" data-testid="object-editor">
        ${AXES.map((axis, i) => html`
          <span>${axis.toUpperCase()} ${unit}</span>
          <input type="number" inputmode="decimal" step=${step} data-testid="pos-${axis}"
            .value=${String(sizeField(d.pose.position[i]))}
            @change=${(e: Event) => this.edit((o, v) => (o.pose.position[i] = v), e)} />
          <button data-testid="nudge-${axis}-minus" ${saves}
            aria-label=${t("scene.editor.nudge_minus", { axis, step, unit })}
            @click=${() => this.nudge(i, -nudge)}>−</button>
          <button data-testid="nudge-${axis}-plus" ${saves}
            aria-label=${t("scene.editor.nudge_plus", { axis, step, unit })}
            @click=${() => this.nudge(i, nudge)}>+</button>`)}
        ${labels.map(([name, label], i) => html`
          <span>${t(name)}</span>
          <input type="number" inputmode="decimal" step=${step} min=${lengthToField(0.001)}
            data-testid="size-${i}" aria-label=${t(label, { unit })}
            .value=${String(sizeField(d.size[i]))}
            @change=${(e: Event) => this.edit((o, v) => (o.size[i] = v), e)} />
          <span class="muted">${unit}</span><span></span>`)}
      </div>
      <label class="check"><input type="checkbox" data-testid="keep-out" .checked=${d.keep_out}
        @change=${(e: Event) => (this.draft = { ...d, keep_out: (e.target as HTMLInputElement).checked })} />
        ${t("scene.editor.keep_out")}</label>
      <div class="row">
        <button class="primary" data-testid="apply" @click=${() => this.save(this.selected, d)} ${saves}
          >${t("scene.editor.apply")}</button>
        <button class="danger" data-testid="delete" @click=${this.deleteSelected}
          ${makes(request("DELETE", `/api/variables/${encodeURIComponent(this.selected)}`))}>
          ${this.confirmDelete ? t("scene.editor.confirm_delete") : t("scene.delete")}</button>
      </div>`;
  }

  render() {
    if (!feed.robots().length) {
      return html`<div class="card"><h2>${t("scene.no_robot")}</h2>
        <p>${t("scene.no_robot_hint")}</p></div>`;
    }
    const names = Object.keys(this.objects).sort();
    const taken = new Set(names);
    const plans = makes(...(this.robot
      ? [request("POST", `/api/motion/robots/${encodeURIComponent(this.robot)}/plan`)] : []));
    return html`
      ${this.message ? html`<p class="error" role="alert" data-testid="scene-message">${this.message}</p>` : ""}
      <div class="layout">
        <div class="view">
          <op-robot-view .model=${this.model}
            .joints=${this.model?.name === this.robot
              ? feed.states.get(this.robot)?.joint_position ?? null : null}
            .world=${this.world()}></op-robot-view>
          <div class="row" style="margin-top:8px">
            <op-clearance-chip .robot=${this.robot}></op-clearance-chip></div>
        </div>
        <div class="side">
          <section class="card">
            <h2>${t("scene.mount.heading", { robot: this.robot })}</h2>
            ${this.mounting()}
          </section>
          <section class="card">
            <h2>${t("scene.tool.heading", { robot: this.robot })}</h2>
            <op-tool-card robot=${this.robot}></op-tool-card>
          </section>
          <section class="card">
            <h2>${t("scene.preview.heading")}</h2>
            <div class="row">
              <select aria-label=${t("scene.preview.target")} data-testid="preview-target" ${plans}
                .value=${this.target}
                @change=${(e: Event) => { this.target = (e.target as HTMLSelectElement).value; void this.runPreview(); }}>
                <option value="">${t("scene.preview.choose")}</option>
                ${this.waypoints.map((w) => html`<option value=${w.name}>${w.name}</option>`)}
              </select>
              <select aria-label=${t("scene.preview.kind")} data-testid="preview-kind" ${plans}
                .value=${this.kind}
                @change=${(e: Event) => { this.kind = (e.target as HTMLSelectElement).value as "joint" | "linear"; void this.runPreview(); }}>
                <option value="joint">${t("scene.preview.joint")}</option>
                <option value="linear">${t("scene.preview.linear")}</option>
              </select>
            </div>
            <label class="check"><input type="checkbox" data-testid="preview-around" .checked=${this.around} ${plans}
              ?disabled=${this.kind !== "joint"}
              @change=${(e: Event) => { this.around = (e.target as HTMLInputElement).checked; void this.runPreview(); }} />
              ${t("scene.preview.around")}</label>
            <div class="row">${this.previewChip()}</div>
          </section>
          <section class="card objects">
            <h2>${t("scene.objects.heading")}</h2>
            <div class="row" style="margin-bottom:8px">
              <button data-testid="add-box" @click=${() => this.add("box")}
                ${makes(request("PUT", `/api/variables/${encodeURIComponent(freeName("box", taken))}`))}
                >${t("scene.objects.add_box")}</button>
              <button data-testid="add-cylinder" @click=${() => this.add("cylinder")}
                ${makes(request("PUT", `/api/variables/${encodeURIComponent(freeName("cylinder", taken))}`))}
                >${t("scene.objects.add_cylinder")}</button>
            </div>
            ${names.length ? "" : html`<p class="muted">${t("scene.objects.none")}</p>`}
            ${names.map((name) => html`
              <button data-testid="scene-object" data-name=${name} aria-pressed=${name === this.selected}
                @click=${() => this.select(name === this.selected ? "" : name)}>
                ${name} <span class="muted">${this.shapeText(this.objects[name])}</span>
              </button>`)}
          </section>
          <section class="card">${this.editor()}</section>
        </div>
      </div>`;
  }
}

customElements.define("op-scene-panel", OpScenePanel);
