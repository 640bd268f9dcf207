import { LitElement, css, html } from "lit";
import { api, errorText } from "../api";
import { FocusController, focus } from "../focus";
import { FeedController, feed } from "../live";
import { quaternionToRpy, rpyToQuaternion } from "../math";
import { RobotLoader } from "../robot-loader";
import { shared } from "../styles";
import type { Obstacle, PathPreview, PoseJson, WorldContents } from "../three/scene";
import "../components/clearance-chip";
import "../components/robot-view";
import "../components/tool-card";
import type { RobotModel } from "../components/robot-view";
import type { Waypoint } from "../components/waypoint-list";

type SceneObject = Omit<Obstacle, "name" | "selected">;

/** Where a robot's base stands in the world: mm and degrees, as people set it. */
interface Mount {
  x: number;
  y: number;
  z: number;
  roll: number;
  pitch: number;
  yaw: number;
}

const MOUNT_FIELDS: [keyof Mount, string][] = [
  ["x", "X mm"],
  ["y", "Y mm"],
  ["z", "Z mm"],
  ["roll", "Roll °"],
  ["pitch", "Pitch °"],
  ["yaw", "Yaw °"],
];

function mountOf(base: PoseJson | null): Mount {
  const p = base?.position ?? [0, 0, 0];
  const [roll, pitch, yaw] = quaternionToRpy(base?.orientation ?? [0, 0, 0, 1]);
  const r = (v: number) => Math.round(v * 10) / 10;
  return { x: r(p[0] * 1000), y: r(p[1] * 1000), z: r(p[2] * 1000),
    roll: r(roll), pitch: r(pitch), yaw: r(yaw) };
}

interface SceneResponse {
  robots: Record<string, { base: PoseJson; joints: number[] }>;
  objects: Record<string, SceneObject>;
}

interface PlanReport {
  ok: boolean;
  code: string;
  message: string;
  collision: { robot_part: string; other: string; position: number[] } | null;
  tcp_path: [number, number, number][];
}

const NUDGE = 0.01; // m per tap
const AXES = ["x", "y", "z"] as const;
const SIZE_LABELS: Record<string, string[]> = {
  box: ["Length X", "Width Y", "Height Z"],
  cylinder: ["Radius", "Height"],
  sphere: ["Radius"],
  mesh: ["Scale X", "Scale Y", "Scale Z"],
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
    const robot = encodeURIComponent(name);
    if (this.model?.name !== name) this.model = null;
    try {
      const model = await api<RobotModel>("GET", `/api/jog/robots/${robot}`);
      if (name !== this.robot) return true; // the focus moved on meanwhile
      this.model = model;
      this.waypoints = await api<Waypoint[]>("GET", `/api/jog/robots/${robot}/waypoints`);
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
    const scene = await api<SceneResponse>("GET", "/api/motion/scene");
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
      const all = await api<{ name: string }[]>("GET", "/api/variables");
      names = new Set(all.map((v) => v.name));
    } catch (err) {
      this.message = errorText(err);
      return;
    }
    let n = 1;
    while (names.has(`${shape}_${n}`)) n += 1;
    const name = `${shape}_${n}`;
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
      await api("PUT", `/api/variables/${encodeURIComponent(name)}`, {
        type: "scene_object",
        value: object,
      });
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
      await api("DELETE", `/api/variables/${encodeURIComponent(name)}`);
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
    const value = Number((e.target as HTMLInputElement).value) / 1000;
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
      this.message = "Every mounting value must be a number.";
      return;
    }
    const pose = {
      position: [m.x / 1000, m.y / 1000, m.z / 1000],
      orientation: rpyToQuaternion(m.roll, m.pitch, m.yaw),
    };
    try {
      await api("PUT", `/api/variables/frames.${encodeURIComponent(this.robot)}`, {
        type: "frame",
        value: { pose },
      });
      this.message = "";
      await this.loadScene();
      await this.runPreview();
    } catch (err) {
      this.message = errorText(err);
    }
  }

  private mounting() {
    const m = this.mount;
    if (!m) return html`<p class="muted">Loading…</p>`;
    return html`<div class="mount" data-testid="mount-editor">
        ${MOUNT_FIELDS.map(([key, label]) => html`<label>
          <span>${label}</span>
          <input type="number" inputmode="decimal" step="10" data-testid="mount-${key}"
            .value=${String(m[key])}
            @change=${(e: Event) => (this.mount = { ...m,
              [key]: Number((e.target as HTMLInputElement).value) })} /></label>`)}
      </div>
      <div class="row">
        <button class="primary" data-testid="save-mount" @click=${() => this.saveMount()}>
          Save mounting</button>
        <span class="muted">Where ${this.robot}'s base stands in the cell (the world frame).</span>
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
      this.preview = await api<PlanReport>(
        "POST",
        `/api/motion/robots/${encodeURIComponent(this.robot)}/plan`,
        {
          kind: this.kind,
          target: { waypoint: this.target },
          avoid_obstacles: this.kind === "joint" && this.around,
        },
      );
    } catch (err) {
      this.preview = { ok: false, code: "error", message: errorText(err), collision: null,
                       tcp_path: [] };
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
    return { base: this.base, obstacles, path };
  }

  // Rendering -------------------------------------------------------------------------------

  private previewChip() {
    if (this.previewing) return html`<span class="chip" data-testid="preview" data-state="busy">Planning…</span>`;
    const p = this.preview;
    if (!p) return html`<span class="chip" data-testid="preview" data-state="none">No preview</span>`;
    if (p.ok) return html`<span class="chip ok" data-testid="preview" data-state="ok">Path is clear</span>`;
    const state = p.code === "collision" ? "collision" : "error";
    return html`<span class="chip bad" data-testid="preview" data-state=${state}>${p.message}</span>`;
  }

  private editor() {
    const d = this.draft;
    if (!d) return html`<p class="muted">Tap an object to move, resize or delete it.</p>`;
    const labels = SIZE_LABELS[d.shape] ?? [];
    return html`
      <div class="grid" data-testid="object-editor">
        ${AXES.map((axis, i) => html`
          <span>${axis.toUpperCase()} mm</span>
          <input type="number" inputmode="decimal" step="10" data-testid="pos-${axis}"
            .value=${String(Math.round(d.pose.position[i] * 1000))}
            @change=${(e: Event) => this.edit((o, v) => (o.pose.position[i] = v), e)} />
          <button data-testid="nudge-${axis}-minus" aria-label="${axis} −10 mm"
            @click=${() => this.nudge(i, -NUDGE)}>−</button>
          <button data-testid="nudge-${axis}-plus" aria-label="${axis} +10 mm"
            @click=${() => this.nudge(i, NUDGE)}>+</button>`)}
        ${labels.map((label, i) => html`
          <span>${label.split(" ")[0]}</span>
          <input type="number" inputmode="decimal" step="10" min="1" data-testid="size-${i}"
            aria-label="${label} mm" .value=${String(Math.round(d.size[i] * 1000))}
            @change=${(e: Event) => this.edit((o, v) => (o.size[i] = v), e)} />
          <span class="muted">mm</span><span></span>`)}
      </div>
      <label class="check"><input type="checkbox" data-testid="keep-out" .checked=${d.keep_out}
        @change=${(e: Event) => (this.draft = { ...d, keep_out: (e.target as HTMLInputElement).checked })} />
        Keep-out zone</label>
      <div class="row">
        <button class="primary" data-testid="apply" @click=${() => this.save(this.selected, d)}>Apply</button>
        <button class="danger" data-testid="delete" @click=${this.deleteSelected}>
          ${this.confirmDelete ? "Tap again to delete" : "Delete"}</button>
      </div>`;
  }

  render() {
    if (!feed.robots().length) {
      return html`<div class="card"><h2>No robot yet</h2>
        <p>Add a robot in the Devices panel; its scene shows here.</p></div>`;
    }
    const names = Object.keys(this.objects).sort();
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
            <h2>Mounting of ${this.robot}</h2>
            ${this.mounting()}
          </section>
          <section class="card">
            <h2>Tool of ${this.robot}</h2>
            <op-tool-card robot=${this.robot}></op-tool-card>
          </section>
          <section class="card">
            <h2>Path preview</h2>
            <div class="row">
              <select aria-label="Target waypoint" data-testid="preview-target" .value=${this.target}
                @change=${(e: Event) => { this.target = (e.target as HTMLSelectElement).value; void this.runPreview(); }}>
                <option value="">Choose a waypoint…</option>
                ${this.waypoints.map((w) => html`<option value=${w.name}>${w.name}</option>`)}
              </select>
              <select aria-label="Move kind" data-testid="preview-kind" .value=${this.kind}
                @change=${(e: Event) => { this.kind = (e.target as HTMLSelectElement).value as "joint" | "linear"; void this.runPreview(); }}>
                <option value="joint">Joint move</option>
                <option value="linear">Linear move</option>
              </select>
            </div>
            <label class="check"><input type="checkbox" data-testid="preview-around" .checked=${this.around}
              ?disabled=${this.kind !== "joint"}
              @change=${(e: Event) => { this.around = (e.target as HTMLInputElement).checked; void this.runPreview(); }} />
              Plan around obstacles</label>
            <div class="row">${this.previewChip()}</div>
          </section>
          <section class="card objects">
            <h2>Objects</h2>
            <div class="row" style="margin-bottom:8px">
              <button data-testid="add-box" @click=${() => this.add("box")}>Add box</button>
              <button data-testid="add-cylinder" @click=${() => this.add("cylinder")}>Add cylinder</button>
            </div>
            ${names.length ? "" : html`<p class="muted">No obstacles yet.</p>`}
            ${names.map((name) => html`
              <button data-testid="scene-object" data-name=${name} aria-pressed=${name === this.selected}
                @click=${() => this.select(name === this.selected ? "" : name)}>
                ${name} <span class="muted">${this.objects[name].shape}${this.objects[name].keep_out ? ", keep-out" : ""}</span>
              </button>`)}
          </section>
          <section class="card">${this.editor()}</section>
        </div>
      </div>`;
  }
}

customElements.define("op-scene-panel", OpScenePanel);
