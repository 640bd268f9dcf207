import { LitElement, css, html } from "lit";
import { client, errorText, ok, type Schemas } from "../api";
import { type StringKey, t } from "../i18n";
import { FeedController, feed } from "../live";
import { makes, request } from "../rights";
import { shared } from "../styles";
import "../vision/camera-view";
import { fileButton } from "../vision/styles";
import type { Box, Overlay } from "../vision/camera-view";
import "../vision/detect-tab";
import "../vision/intrinsic-tab";
import "../vision/origin-tab";
import "../vision/placement-tab";
import "../vision/template-tab";

// The Vision panel: a camera's live picture with what each step lays over it, and the steps:
// detecting, calibrating the camera (intrinsics), placing it in the world, finding where a
// robot stands, teaching a template. The camera's calibration is shown, and goes out and
// comes in as OpenCV's YAML.

type Step = "detect" | "intrinsic" | "placement" | "origin" | "template";
const STEPS: Step[] = ["detect", "intrinsic", "placement", "origin", "template"];

type Calibration = Schemas["CameraCalibration"];

export class OpVisionPanel extends LitElement {
  static properties = {
    camera: { state: true },
    step: { state: true },
    overlays: { state: true },
    box: { state: true },
    calibration: { state: true },
    placed: { state: true },
    error: { state: true },
  };
  declare camera: string;
  declare step: Step;
  declare overlays: Partial<Record<Step, Overlay>>;
  declare box: Box | null;
  declare calibration: Calibration | null;
  declare placed: boolean;
  declare error: string;
  private shownFor = "";

  static styles = [
    shared,
    fileButton,
    css`
      .layout {
        display: grid;
        grid-template-columns: minmax(0, 3fr) minmax(340px, 2fr);
        gap: 16px;
        align-items: start;
      }
      op-camera-view {
        position: sticky;
        top: 0;
        z-index: 1;
      }
      @media (max-width: 1000px) {
        .layout {
          grid-template-columns: 1fr;
        }
        op-camera-view {
          position: static;
        }
      }
      .bar {
        display: flex;
        flex-wrap: wrap;
        align-items: center;
        gap: 8px;
        margin-bottom: 10px;
      }
      .steps {
        display: flex;
        flex-wrap: wrap;
        gap: 6px;
        margin-bottom: 12px;
      }
      .steps button {
        padding: 0 14px;
      }
      button[aria-pressed="true"] {
        border-color: var(--accent);
        color: var(--accent);
      }
      [hidden] {
        display: none !important;
      }
    `,
  ];

  constructor() {
    super();
    new FeedController(this);
    this.camera = "";
    this.step = "detect";
    this.overlays = {};
    this.box = null;
    this.calibration = null;
    this.placed = false;
    this.error = "";
  }

  private cameras(): string[] {
    return feed.devices.filter((d) => d.kind === "camera").map((d) => d.local_name);
  }

  protected willUpdate(): void {
    const cameras = this.cameras();
    if (!cameras.includes(this.camera)) this.camera = cameras[0] ?? "";
    if (this.camera !== this.shownFor) {
      this.shownFor = this.camera;
      this.overlays = {};
      this.box = null;
      this.calibration = null;
      this.placed = false;
      void this.loadCalibration();
    }
  }

  /** The camera's stored calibration and placement, read from the variables (lists, so
   * a camera with neither is no failed request). */
  private async loadCalibration(): Promise<void> {
    const camera = this.camera;
    if (!camera) return;
    try {
      const [calibrations, frames] = await Promise.all([
        ok(client.GET("/api/variables", { params: { query: { type: "camera_calibration" } } })),
        ok(client.GET("/api/variables", { params: { query: { type: "frame" } } })),
      ]);
      if (camera !== this.camera) return;
      // A variable's value is its type's (the storage checked it on the way in).
      const calibration = calibrations.find((v) => v.name === `calibration.${camera}`);
      this.calibration = (calibration?.value as Calibration | undefined) ?? null;
      this.placed = frames.some((v) => v.name === `frames.${camera}`
        && (v.value as { parent?: unknown } | null)?.parent === "world");
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private async importYaml(e: Event): Promise<void> {
    const input = e.target as HTMLInputElement;
    const file = input.files?.[0];
    input.value = "";
    if (!file) return;
    this.error = "";
    try {
      await ok(client.PUT("/api/vision/cameras/{camera}/calibration.yaml", {
        params: { path: { camera: this.camera } },
        body: await file.text(),
        bodySerializer: (text: string) => text, // the file as it is, not as JSON
        headers: { "content-type": "application/x-yaml" },
      }));
    } catch (err) {
      this.error = errorText(err);
    }
    await this.loadCalibration();
  }

  private calibrationBar() {
    const c = this.calibration;
    const camera = encodeURIComponent(this.camera);
    return html`<div class="bar">
      ${c
        ? html`<span class="chip ok" data-testid="vision-calibrated">${t("vision.calibrated", { rms: c.rms.toFixed(2) })}</span>`
        : html`<span class="chip warn" data-testid="vision-not-calibrated">${t("vision.not_calibrated")}</span>`}
      <span class="chip ${this.placed ? "ok" : "warn"}" data-testid="vision-placed"
        >${this.placed ? t("vision.placed") : t("vision.not_placed")}</span>
      ${c ? html`<a class="file" href="/api/vision/cameras/${camera}/calibration.yaml" download>${t("vision.export")}</a>` : ""}
      <label class="file" data-testid="vision-import-label"
        ${makes(request("PUT", `/api/vision/cameras/${camera}/calibration.yaml`))}>${t("vision.import")}
        <input type="file" accept=".yaml,.yml,application/x-yaml,text/yaml"
          data-testid="vision-import" @change=${(e: Event) => void this.importYaml(e)} /></label>
    </div>`;
  }

  /** Every step stays made while the panel is open (hidden when not chosen): a solve or a
   * robot-origin run goes on, and its Cancel is there, when the user looks at another. */
  private stepView(step: Step) {
    const camera = this.camera;
    const active = step === this.step;
    switch (step) {
      case "intrinsic":
        return html`<op-intrinsic-tab data-step=${step} ?hidden=${!active} .camera=${camera}
          @calibrated=${() => void this.loadCalibration()}></op-intrinsic-tab>`;
      case "placement":
        return html`<op-placement-tab data-step=${step} ?hidden=${!active} .camera=${camera}
          @placed=${() => void this.loadCalibration()}></op-placement-tab>`;
      case "origin":
        return html`<op-origin-tab data-step=${step} ?hidden=${!active} .camera=${camera}></op-origin-tab>`;
      case "template":
        return html`<op-template-tab data-step=${step} ?hidden=${!active} .camera=${camera}
          .box=${this.box}></op-template-tab>`;
      default:
        return html`<op-detect-tab data-step=${step} ?hidden=${!active} .active=${active}
          .camera=${camera}></op-detect-tab>`;
    }
  }

  private choose(step: Step): void {
    this.step = step;
    void this.loadCalibration();
  }

  /** What a step lays over the picture, kept per step: shown while it is the chosen one. */
  private onOverlay(e: CustomEvent<Overlay>): void {
    const step = (e.target as HTMLElement).dataset.step as Step | undefined;
    if (step) this.overlays = { ...this.overlays, [step]: e.detail };
  }

  render() {
    const cameras = this.cameras();
    if (cameras.length === 0) {
      return html`<h2>${t("app.panel.vision")}</h2>
        <p class="card" data-testid="vision-none">${t("vision.none")}</p>`;
    }
    return html`
      <h2>${t("app.panel.vision")}</h2>
      <div class="bar">
        ${cameras.map(
          (c) => html`<button data-testid="vision-camera-${c}" aria-pressed=${c === this.camera}
            @click=${() => (this.camera = c)} translate="no">${c}</button>`,
        )}
      </div>
      ${this.calibrationBar()}
      <div class="layout">
        <op-camera-view .camera=${this.camera} .overlay=${this.overlays[this.step] ?? {}}
          ?drawing=${this.step === "template"}
          @box=${(e: CustomEvent<Box>) => (this.box = e.detail)}></op-camera-view>
        <section class="card" @overlay=${(e: CustomEvent<Overlay>) => this.onOverlay(e)}>
          <div class="steps" role="tablist">
            ${STEPS.map(
              (s) => html`<button role="tab" data-testid="vision-step-${s}" aria-pressed=${s === this.step}
                @click=${() => this.choose(s)}>${t(`vision.step.${s}` as StringKey)}</button>`,
            )}
          </div>
          ${STEPS.map((s) => this.stepView(s))}
        </section>
      </div>
      ${this.error ? html`<p class="error" role="alert" data-testid="vision-error">${this.error}</p>` : ""}
    `;
  }
}

customElements.define("op-vision-panel", OpVisionPanel);
