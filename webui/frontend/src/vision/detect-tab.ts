import { html } from "lit";
import { errorText } from "../api";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
import {
  DETECTOR_PREFIX,
  type Detections,
  detect,
  detectionList,
  detectorsOf,
  detects,
  overlayOf,
} from "./detections";
import "./detector-form";
import { VisionStep } from "./step";
import { visionStyles } from "./styles";

// Detecting with the camera's stored detectors: once, or again and again (each detection as
// soon as the last answered), the boxes laid over the live picture.

export class OpDetectTab extends VisionStep {
  static properties = {
    camera: { type: String },
    active: { type: Boolean },
    detectors: { state: true },
    chosen: { state: true },
    found: { state: true },
    running: { state: true },
    adding: { state: true },
  };
  declare camera: string;
  declare active: boolean;
  declare detectors: string[];
  declare chosen: string;
  declare found: Detections | null;
  declare running: boolean;
  declare adding: boolean;

  static styles = [shared, visionStyles];

  constructor() {
    super();
    this.camera = "";
    this.active = true;
    this.detectors = [];
    this.chosen = "";
    this.found = null;
    this.running = false;
    this.adding = false;
  }

  disconnectedCallback(): void {
    super.disconnectedCallback();
    this.running = false;
  }

  protected willUpdate(changed: Map<string, unknown>): void {
    if (changed.has("active") && !this.active) this.running = false; // not while unseen
    if (changed.has("active") && this.active) void this.load();
    if (changed.has("camera")) {
      this.running = false;
      this.found = null;
      void this.load();
    }
  }

  private async load(): Promise<void> {
    try {
      this.detectors = this.camera ? await detectorsOf(this.camera) : [];
      if (!this.detectors.includes(this.chosen)) this.chosen = this.detectors[0] ?? "";
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private async added(name: string): Promise<void> {
    this.adding = false;
    await this.load();
    if (this.detectors.includes(name)) this.chosen = name;
  }

  private async once(): Promise<boolean> {
    this.error = "";
    const camera = this.camera;
    try {
      const found = await detect(this.chosen);
      if (camera !== this.camera) return false; // another camera chosen meanwhile
      this.found = found;
      this.emitOverlay(overlayOf(found));
      return true;
    } catch (err) {
      this.error = errorText(err);
      return false;
    }
  }

  private async keepDetecting(): Promise<void> {
    this.running = true;
    const camera = this.camera;
    while (this.running && this.active && this.isConnected && this.camera === camera) {
      if (!(await this.once())) break;
    }
    this.running = false;
  }

  render() {
    const none = this.detectors.length === 0;
    return html`
      ${none
        ? html`<p class="muted" data-testid="detect-none">${t("vision.detect.none", { camera: this.camera })}</p>`
        : html`<div class="fields">
            <label>${t("vision.detect.detector")}
              <select data-testid="detect-detector" .value=${this.chosen}
                @change=${(e: Event) => (this.chosen = (e.target as HTMLSelectElement).value)}>
                ${this.detectors.map((d) => html`<option value=${d} ?selected=${d === this.chosen}>${d}</option>`)}
              </select></label>
          </div>
          <div class="actions">
            <button class="primary" data-testid="detect-once" ?disabled=${this.running}
              ${detects(this.chosen)}
              @click=${() => void this.once()}>${t("vision.detect.once")}</button>
            ${this.running
              ? html`<button data-testid="detect-stop" @click=${() => (this.running = false)}>${t("vision.detect.stop")}</button>`
              : html`<button data-testid="detect-live" @click=${() => void this.keepDetecting()}
                  ${detects(this.chosen)}>${t("vision.detect.live")}</button>`}
            <button @click=${() => void this.load()}>${t("vision.detect.reload")}</button>
          </div>`}
      <div class="actions">
        <!-- The form it opens saves the detector under the name typed there. -->
        <button data-testid="detector-add" aria-pressed=${this.adding}
          ${makes(request("PUT", `/api/variables/${DETECTOR_PREFIX}new`))}
          @click=${() => (this.adding = !this.adding)}>${t("vision.detect.add")}</button>
      </div>
      ${this.adding
        ? html`<op-detector-form .camera=${this.camera} @saved=${(e: CustomEvent<string>) => void this.added(e.detail)}></op-detector-form>`
        : ""}
      ${detectionList(this.found)}
      ${this.error ? html`<p class="error" role="alert" data-testid="detect-error">${this.error}</p>` : ""}
    `;
  }
}

customElements.define("op-detect-tab", OpDetectTab);
