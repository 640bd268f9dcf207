import { LitElement, css, html } from "lit";
import { client, ok, type Schemas } from "../api";
import { FocusController, focus } from "../focus";
import { t } from "../i18n";
import { Listening } from "../listening";
import { FeedController, feed } from "../live";
import { robotBases } from "../robot-bases";
import { shared } from "../styles";
import { CellModels } from "./cell-models";
import type {
  CellPart,
  DrawnRobotReport,
  Marker,
  PoseJson,
  RobotScene,
  WorldContents,
} from "../three/scene";

// How often a simulated cell's parts are asked for: a part carried by the gripper follows
// the arm about this late.
const PARTS_EVERY_MS = 300;

/** A robot's URDF and info: the joints of another robot are never drawn on it. */
export type RobotModel = Schemas["RobotModel"];

/** A robot's drawing: its URDF, drawn, still loading, or failed with the reason. */
interface Drawing {
  urdf: string;
  state: "loading" | "drawn" | "failed";
  error: string;
}

function sameValues(a: number[] | undefined, b: number[]): boolean {
  return !!a && a.length === b.length && a.every((v, i) => v === b[i]);
}

// The live 3D view of the whole cell: every added robot on its base in the world, the one in
// focus drawn as it is and the others faint, each posed from its live joints. The panel gives
// the focused robot's model and joints; the others' the view asks for and follows itself.
// three.js and the URDF loader load only when a view is first shown.
export class OpRobotView extends LitElement {
  static properties = {
    model: { attribute: false },
    joints: { attribute: false },
    markers: { attribute: false },
    world: { attribute: false },
    status: { state: true },
    progress: { state: true },
    drawnParts: { state: true },
  };
  declare model: RobotModel | null; // the robot in focus
  declare joints: number[] | null; // of the robot in `model`
  declare markers: Marker[];
  declare world: WorldContents | null; // obstacles and a path preview, when shown
  declare status: "loading" | "ready" | "error"; // of the robot in `model`
  declare progress: string;
  declare drawnParts: string; // what the view shows of the cell's parts: "id@x,y,z …"
  private scene: RobotScene | null = null;
  private creating: Promise<RobotScene | null> | null = null;
  private life = 0; // one more each time the view leaves the page: what was under way ends
  private models = new CellModels(() => this.requestUpdate());
  private drawings = new Map<string, Drawing>();
  private shownJoints = new Map<string, number[]>();
  private shownBases = new Map<string, string>();
  private readyFor: RobotModel | null = null;
  private shownMarkers = "";
  private shownWorld = "";
  private observer = new ResizeObserver(() => this.scene?.resize());
  private stopBases: (() => void) | null = null;
  private readonly basesChanged = () => this.requestUpdate();
  private partsTimer = 0;
  private partsRound = 0;
  private shownParts = "";

  static styles = [
    shared,
    css`
      :host {
        display: block;
        position: relative;
        min-height: 260px;
        border-radius: 14px;
        overflow: hidden;
        background: var(--view-bg);
        border: 1px solid var(--line);
      }
      .canvas,
      .canvas canvas {
        width: 100%;
        height: 100%;
        display: block;
        touch-action: pan-y; /* one finger scrolls the page; two turn and zoom the view */
      }
      .reset {
        position: absolute;
        top: 8px;
        right: 8px;
        min-height: 48px;
        padding: 0 12px;
        font-size: 15px;
        opacity: 0.85;
      }
      .overlay {
        position: absolute;
        inset: auto 10px 10px 10px;
        pointer-events: none;
      }
    `,
  ];

  constructor() {
    super();
    new Listening(this, robotBases, "change", this.basesChanged);
    new FeedController(this);
    new FocusController(this);
    this.model = null;
    this.joints = null;
    this.markers = [];
    this.world = null;
    this.status = "loading";
    this.progress = "";
    this.drawnParts = "";
  }

  connectedCallback(): void {
    super.connectedCallback();
    this.stopBases = robotBases.use();
  }

  disconnectedCallback(): void {
    this.life++;
    window.clearTimeout(this.partsTimer);
    this.partsRound++;
    this.observer.disconnect();
    this.scene?.dispose();
    this.scene = null;
    this.creating = null;
    this.drawings.clear();
    this.models.stop();
    this.shownJoints.clear();
    this.shownBases.clear();
    this.readyFor = null;
    this.stopBases?.();
    this.stopBases = null;
    super.disconnectedCallback();
  }

  /** What the view draws of each robot, where, and whether faint: a read-only hook for
   * tests. */
  drawnRobots(): DrawnRobotReport[] {
    return this.scene?.drawn() ?? [];
  }

  protected updated(changed: Map<string, unknown>): void {
    if (changed.has("model") && this.model?.urdf) {
      const given = this.model;
      const drawing = this.drawings.get(given.name);
      // The same model given again after it failed is tried again.
      if (drawing?.state === "failed" && drawing.urdf === given.urdf) {
        this.drawings.delete(given.name);
      }
      this.models.give(given);
    }
    this.followCell();
    this.showStatus();
    const scene = this.scene;
    if (!scene) return;
    scene.setFocus(focus.robot);
    this.showBases(scene);
    this.showJoints(scene);
    if (this.status !== "ready") return;
    // The panel re-renders with every state; only real changes reach the scene ("" is
    // nothing shown yet).
    if (changed.has("markers") || !this.shownMarkers) {
      const markers = JSON.stringify(this.markers);
      if (markers !== this.shownMarkers) scene.setMarkers(this.markers);
      this.shownMarkers = markers;
    }
    if (this.world && (changed.has("world") || !this.shownWorld)) {
      const world = JSON.stringify(this.world);
      if (world !== this.shownWorld) scene.setWorld(this.world);
      this.shownWorld = world;
    }
  }

  /** Every robot of the cell drawn (again if its URDF changed); those gone taken away. */
  private followCell(): void {
    for (const name of this.models.follow()) {
      this.drawings.delete(name);
      this.shownJoints.delete(name);
      this.shownBases.delete(name);
      this.scene?.removeRobot(name);
    }
    for (const [name, model] of this.models.entries()) {
      if (model.urdf && this.drawings.get(name)?.urdf !== model.urdf) void this.draw(name, model);
    }
  }

  private sceneReady(): Promise<RobotScene | null> {
    if (this.scene) return Promise.resolve(this.scene);
    const life = this.life;
    this.creating ??= import("../three/scene")
      .then(({ RobotScene }) => {
        if (life !== this.life) return null;
        const host = this.renderRoot.querySelector(".canvas") as HTMLElement;
        this.scene = new RobotScene(host);
        this.scene.setFocus(focus.robot); // before any robot is drawn faint or not
        this.observer.observe(host);
        return this.scene;
      })
      .catch((err: unknown) => {
        if (life === this.life) this.creating = null; // tried again with the next robot
        throw err;
      });
    return this.creating;
  }

  private async draw(name: string, model: RobotModel): Promise<void> {
    const urdf = model.urdf ?? "";
    const life = this.life;
    const drawing: Drawing = { urdf, state: "loading", error: "" };
    this.drawings.set(name, drawing);
    const current = () => life === this.life && this.drawings.get(name) === drawing;
    try {
      const scene = await this.sceneReady();
      if (!scene || !current()) return;
      const source = {
        urdf,
        packages: model.packages,
        baseLink: model.info.base_link,
        flangeLink: model.info.flange_link,
      };
      const drawn = await scene.addRobot(name, source, (done, total) => {
        if (current() && name === this.model?.name) {
          this.progress = t("scene.view.loading", { done, total });
        }
      });
      if (!drawn || !current()) return;
      drawing.state = "drawn";
      this.shownJoints.delete(name);
      this.shownBases.delete(name);
    } catch (err) {
      if (!current()) return;
      drawing.state = "failed";
      drawing.error = err instanceof Error ? err.message : String(err);
    }
    this.requestUpdate();
  }

  /** The status of the robot the panel gave. Once drawn, its markers, the world and its
   * parts are shown afresh. */
  private showStatus(): void {
    const model = this.model;
    if (!model?.urdf) return; // none given (yet): what is shown stays
    const drawing = this.drawings.get(model.name);
    if (drawing?.urdf !== model.urdf || drawing.state === "loading") {
      this.status = "loading";
      this.readyFor = null;
    } else if (drawing.state === "failed") {
      this.status = "error";
      this.readyFor = null;
      this.progress = t("scene.view.unavailable", { error: drawing.error });
    } else if (this.readyFor !== model) {
      this.readyFor = model;
      this.status = "ready";
      this.progress = "";
      this.shownMarkers = "";
      this.shownWorld = "";
      this.shownParts = "";
      window.clearTimeout(this.partsTimer);
      void this.followParts(++this.partsRound);
    }
  }

  private showBases(scene: RobotScene): void {
    for (const [name] of this.models.entries()) {
      const base: PoseJson | null = robotBases.base(name);
      const key = JSON.stringify(base);
      if (this.shownBases.get(name) === key) continue;
      this.shownBases.set(name, key);
      scene.setBase(name, base);
    }
  }

  /** Each drawn robot at its live joints: the panel's robot at `joints`, the others at their
   * latest state (a robot whose link is down stays where it was last seen). */
  private showJoints(scene: RobotScene): void {
    for (const [name, drawing] of this.drawings) {
      const model = this.models.get(name);
      if (drawing.state !== "drawn" || !model) continue;
      const joints = name === this.model?.name
        ? this.joints
        : feed.states.get(name)?.joint_position ?? null;
      if (!joints || sameValues(this.shownJoints.get(name), joints)) continue;
      this.shownJoints.set(name, joints);
      scene.setJoints(name, model.info.joints.map((j) => j.name), joints);
    }
  }

  /** A simulated robot's parts, asked for again and again while a robot is shown; none
   * drawn while they cannot be had (the last answer would be a guess). One round at a time:
   * a new load ends the rounds of the one before. */
  private async followParts(round: number): Promise<void> {
    const model = this.model;
    if (round !== this.partsRound || !model || !this.scene || !this.isConnected) return;
    if (!model.info.capabilities.includes("sim_cell")) {
      this.showParts([]);
      return;
    }
    const linked = feed.robots().some((d) => d.local_name === model.name && d.status === "connected");
    if (!linked) this.showParts([]); // nothing to ask (and nothing known) while its link is down
    else if (!document.hidden) {
      let parts: CellPart[] = [];
      try {
        parts = await ok(client.GET("/api/devices/{local_name}/cell/parts",
          { params: { path: { local_name: model.name } } }));
      } catch {
        parts = [];
      }
      if (round !== this.partsRound || model.name !== this.model?.name) return;
      this.showParts(parts);
    }
    this.partsTimer = window.setTimeout(() => void this.followParts(round), PARTS_EVERY_MS);
  }

  private showParts(parts: CellPart[]): void {
    const text = JSON.stringify(parts);
    if (!this.scene || text === this.shownParts) return;
    this.shownParts = text;
    this.drawnParts = this.scene.setParts(parts).join(" ");
  }

  render() {
    return html`<div class="canvas" data-testid="robot-view" data-status=${this.status}
        data-robot=${this.model?.name ?? ""}
        data-parts=${this.drawnParts}></div>
      ${this.status === "ready"
        ? html`<button class="reset" data-testid="reset-view" title=${t("scene.view.reset_title")}
            @click=${() => this.scene?.resetView()}>${t("scene.view.reset")}</button>`
        : ""}
      ${this.progress ? html`<div class="overlay muted">${this.progress}</div>` : ""}`;
  }
}

customElements.define("op-robot-view", OpRobotView);
