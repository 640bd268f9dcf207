import { html } from "lit";
import { client, ok } from "../api";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
import { lengthFromField, lengthToField, lengthUnit } from "../units";
import type { Box } from "./camera-view";
import { type Detections, detect, detectionList, detects, overlayOf } from "./detections";
import { VisionStep } from "./step";
import { visionStyles } from "./styles";

// Teaching a template detector: a box drawn around the part on the live picture with a
// finger, cut from a new frame (PUT /vision/detectors/{name}/template) and stored as
// `detectors.<name>`; then tried at once.

const NAME = /^[a-z][a-z0-9_]{0,31}$/;

export class OpTemplateTab extends VisionStep {
  static properties = {
    camera: { type: String },
    box: { attribute: false },
    name: { state: true },
    label: { state: true },
    height: { state: true },
    taught: { state: true },
    found: { state: true },
  };
  declare camera: string;
  declare box: Box | null;
  declare name: string;
  declare label: string;
  declare height: number;
  declare taught: string;
  declare found: Detections | null;

  static styles = [shared, visionStyles];

  constructor() {
    super();
    this.camera = "";
    this.box = null;
    this.name = "part";
    this.label = "part";
    this.height = 0;
    this.taught = "";
    this.found = null;
  }

  protected willUpdate(changed: Map<string, unknown>): void {
    if (changed.has("camera") && changed.get("camera") !== undefined) {
      this.taught = "";
      this.found = null;
    }
  }

  private teach(): Promise<void> {
    return this.act(async () => {
      if (!NAME.test(this.name)) throw new Error(t("vision.template.bad_name"));
      const box = this.box;
      if (!box) throw new Error(t("vision.template.draw"));
      await ok(client.PUT("/api/vision/detectors/{name}/template", {
        params: { path: { name: this.name } },
        body: { camera: this.camera, box, label: this.label.trim() || "part", height: this.height },
      }));
      this.taught = this.name;
      this.found = null;
    });
  }

  private test(): Promise<void> {
    return this.act(async () => {
      this.found = await detect(this.taught);
      this.emitOverlay(overlayOf(this.found));
    });
  }

  render() {
    const b = this.box;
    return html`
      <p class="muted">${t("vision.template.intro")}</p>
      <div class="fields">
        <label>${t("vision.template.name")}
          <input data-testid="template-name" .value=${this.name} autocapitalize="off"
            @input=${(e: Event) => (this.name = (e.target as HTMLInputElement).value.trim())} /></label>
        <label>${t("vision.template.label")}
          <input data-testid="template-label" .value=${this.label}
            @input=${(e: Event) => (this.label = (e.target as HTMLInputElement).value)} /></label>
        <label>${t("vision.template.height", { unit: lengthUnit() })}
          <input type="number" step="any" inputmode="decimal" data-testid="template-height"
            .value=${String(lengthToField(this.height))}
            @change=${(e: Event) => {
              const value = Number((e.target as HTMLInputElement).value);
              if (Number.isFinite(value)) this.height = lengthFromField(value);
            }} /></label>
      </div>
      <p data-testid="template-box" data-box=${b ? `${b.x},${b.y},${b.width},${b.height}` : ""}>
        ${b ? t("vision.template.box", { x: b.x, y: b.y, width: b.width, height: b.height }) : t("vision.template.draw")}
      </p>
      <div class="actions">
        <button class="primary" data-testid="template-teach"
          ?disabled=${this.busy || !b || !this.camera}
          ${makes(request("PUT",
            `/api/vision/detectors/${encodeURIComponent(this.name || "new")}/template`))}
          @click=${() => void this.teach()}>${t("vision.template.teach")}</button>
        <button data-testid="template-test" ?disabled=${this.busy || !this.taught}
          ${detects(this.taught)}
          @click=${() => void this.test()}>${t("vision.template.test")}</button>
      </div>
      ${this.taught ? html`<p class="chip ok" data-testid="template-taught">${t("vision.template.taught", { name: `detectors.${this.taught}` })}</p>` : ""}
      ${detectionList(this.found)}
      ${this.error ? html`<p class="error" role="alert" data-testid="template-error">${this.error}</p>` : ""}
    `;
  }
}

customElements.define("op-template-tab", OpTemplateTab);
