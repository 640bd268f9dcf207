import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { shared } from "../styles";
import type { Marker, RobotScene, WorldContents } from "../three/scene";

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
  };
  declare model: RobotModel | null;
  declare joints: number[] | null;
  declare markers: Marker[];
  declare world: WorldContents | null; // obstacles and a path preview, when shown
  declare status: "loading" | "ready" | "error";
  declare progress: string;
  private scene: RobotScene | null = null;
  private shownMarkers = "";
  private shownWorld = "";
  private shownJoints = "";
  private observer = new ResizeObserver(() => this.scene?.resize());
  private loadedUrdf = "";

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
  }

  disconnectedCallback(): void {
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
    } catch (err) {
      this.loadedUrdf = ""; // the same model given again is tried again
      this.status = "error";
      const error = err instanceof Error ? err.message : String(err);
      this.progress = t("scene.view.unavailable", { error });
    }
  }

  render() {
    return html`<div class="canvas" data-testid="robot-view" data-status=${this.status}
        data-robot=${this.model?.name ?? ""}></div>
      ${this.status === "ready"
        ? html`<button class="reset" data-testid="reset-view" title=${t("scene.view.reset_title")}
            @click=${() => this.scene?.resetView()}>${t("scene.view.reset")}</button>`
        : ""}
      ${this.progress ? html`<div class="overlay muted">${this.progress}</div>` : ""}`;
  }
}

customElements.define("op-robot-view", OpRobotView);
