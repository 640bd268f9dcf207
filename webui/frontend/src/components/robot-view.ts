import { LitElement, css, html } from "lit";
import { api } from "../api";
import { t } from "../i18n";
import { feed } from "../live";
import { shared } from "../styles";
import type { CellPart, Marker, RobotScene, WorldContents } from "../three/scene";

// How often a simulated cell's parts are asked for: a part carried by the gripper follows
// the arm about this late.
const PARTS_EVERY_MS = 300;

export interface RobotModel {
  name: string; // the robot it describes: joints of another robot are never drawn on it
  urdf: string | null;
  packages: Record<string, string>;
  info: { base_link: string; joints: { name: string }[]; capabilities: string[] };
}

// The live 3D view. three.js and the URDF loader load only when a view is first shown.
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
  declare model: RobotModel | null;
  declare joints: number[] | null;
  declare markers: Marker[];
  declare world: WorldContents | null; // obstacles and a path preview, when shown
  declare status: "loading" | "ready" | "error";
  declare progress: string;
  declare drawnParts: string; // what the view shows of the cell's parts: "id@x,y,z …"
  private scene: RobotScene | null = null;
  private shownMarkers = "";
  private shownWorld = "";
  private shownJoints = "";
  private observer = new ResizeObserver(() => this.scene?.resize());
  private loadedUrdf = "";
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
    this.model = null;
    this.joints = null;
    this.markers = [];
    this.world = null;
    this.status = "loading";
    this.progress = "";
    this.drawnParts = "";
  }

  disconnectedCallback(): void {
    window.clearTimeout(this.partsTimer);
    this.partsRound++;
    this.observer.disconnect();
    this.scene?.dispose();
    this.scene = null;
    this.loadedUrdf = "";
    super.disconnectedCallback();
  }

  protected async updated(changed: Map<string, unknown>): Promise<void> {
    if (changed.has("model")) await this.load();
    if (!this.scene || this.status !== "ready") return;
    // The panel re-renders with every state; only real changes reach the scene.
    const joints = JSON.stringify(this.joints);
    if (changed.has("joints") && this.joints && this.model && joints !== this.shownJoints) {
      this.shownJoints = joints;
      this.scene.setJoints(this.model.info.joints.map((j) => j.name), this.joints);
    }
    const markers = JSON.stringify(this.markers);
    if (changed.has("markers") && markers !== this.shownMarkers) {
      this.shownMarkers = markers;
      this.scene.setMarkers(this.markers);
    }
    this.showWorld();
  }

  private showWorld(): void {
    const world = JSON.stringify(this.world);
    if (!this.scene || !this.world || world === this.shownWorld) return;
    this.shownWorld = world;
    this.scene.setWorld(this.world);
  }

  private async load(): Promise<void> {
    const model = this.model;
    if (!model?.urdf || model.urdf === this.loadedUrdf) return;
    this.loadedUrdf = model.urdf;
    this.status = "loading";
    try {
      const { RobotScene } = await import("../three/scene");
      const host = this.renderRoot.querySelector(".canvas") as HTMLElement;
      this.scene?.dispose();
      this.scene = new RobotScene(host);
      this.observer.observe(host);
      await this.scene.load(model.urdf, model.packages, model.info.base_link, (done, total) => {
        this.progress = t("scene.view.loading", { done, total });
      });
      this.status = "ready";
      this.progress = "";
      if (this.joints) this.scene.setJoints(model.info.joints.map((j) => j.name), this.joints);
      this.scene.setMarkers(this.markers);
      this.shownJoints = JSON.stringify(this.joints);
      this.shownMarkers = JSON.stringify(this.markers);
      this.shownWorld = "";
      this.showWorld();
      this.shownParts = "";
      window.clearTimeout(this.partsTimer);
      void this.followParts(++this.partsRound);
    } catch (err) {
      this.loadedUrdf = ""; // the same model given again is tried again
      this.status = "error";
      const error = err instanceof Error ? err.message : String(err);
      this.progress = t("scene.view.unavailable", { error });
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
        const path = `/api/devices/${encodeURIComponent(model.name)}/cell/parts`;
        parts = await api<CellPart[]>("GET", path);
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
