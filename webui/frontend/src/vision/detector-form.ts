import { LitElement, html } from "lit";
import { client, errorText, ok } from "../api";
import { session } from "../session";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
import { DETECTOR_PREFIX } from "./detections";
import { lengthField, numberField } from "./fields";
import { DICTIONARIES } from "./intrinsic-tab";
import { fileButton, visionStyles } from "./styles";

// A new detector for the camera, stored as `detectors.<name>` (the variable type checks
// every setting): ArUco markers of a dictionary and printed size, or a YOLO-style network
// from the data directory's `models/`. Templates are taught on the picture instead.

const NAME = /^[a-z][a-z0-9_]{0,31}$/;

interface Draft {
  name: string;
  method: "aruco" | "neural";
  dictionary: string;
  marker_size: number;
  model: string;
  classes: string;
  layout: "yolov8" | "yolov5";
  input_size: number;
  threshold: number;
  height: number;
}

export class OpDetectorForm extends LitElement {
  static properties = {
    camera: { type: String },
    draft: { state: true },
    models: { state: true },
    uploading: { state: true },
    busy: { state: true },
    error: { state: true },
  };
  declare camera: string;
  declare draft: Draft;
  declare models: string[];
  declare uploading: number | null; // the share sent, while a network is uploaded
  declare busy: boolean;
  declare error: string;

  static styles = [shared, visionStyles, fileButton];

  constructor() {
    super();
    this.camera = "";
    this.draft = {
      name: "tags",
      method: "aruco",
      dictionary: "4x4_50",
      marker_size: 0.032,
      model: "",
      classes: "",
      layout: "yolov8",
      input_size: 640,
      threshold: 0.5,
      height: 0,
    };
    this.models = [];
    this.uploading = null;
    this.busy = false;
    this.error = "";
  }

  connectedCallback(): void {
    super.connectedCallback();
    void ok(client.GET("/api/vision/models"))
      .then((models) => {
        this.models = models;
        if (!this.draft.model && models.length) this.set({ model: models[0] });
      })
      .catch((err: unknown) => (this.error = errorText(err)));
  }

  /** A network's file sent as it is (its bytes), the share sent shown as it goes. */
  private upload(e: Event): void {
    const input = e.target as HTMLInputElement;
    const file = input.files?.[0];
    input.value = "";
    if (!file) return;
    this.error = "";
    this.uploading = 0;
    const xhr = new XMLHttpRequest();
    // The file's own name as a model's name may be (letters, digits, _ . -, ending .onnx).
    const stem = file.name.replace(/\.onnx$/i, "").replace(/[^A-Za-z0-9_.-]+/g, "_").replace(/^[^A-Za-z0-9]+/, "");
    const name = `${stem.slice(0, 60) || "model"}.onnx`;
    xhr.open("PUT", `/api/vision/models/${encodeURIComponent(name)}`);
    xhr.setRequestHeader("content-type", "application/octet-stream");
    if (session.csrf) xhr.setRequestHeader("x-csrf-token", session.csrf);
    xhr.upload.onprogress = (p) => {
      if (p.lengthComputable) this.uploading = p.loaded / p.total;
    };
    xhr.onload = () => {
      this.uploading = null;
      if (xhr.status >= 200 && xhr.status < 300) {
        this.models = JSON.parse(xhr.responseText) as string[];
        this.set({ model: name });
        return;
      }
      const body = (() => {
        try {
          return JSON.parse(xhr.responseText) as { error?: { message?: string } };
        } catch {
          return null;
        }
      })();
      this.error = body?.error?.message ?? t("app.request_failed", { status: xhr.status });
    };
    xhr.onerror = () => {
      this.uploading = null;
      this.error = t("app.unreachable");
    };
    xhr.send(file);
  }

  private uploadControl() {
    if (this.uploading !== null) {
      return html`<div class="operation" data-testid="model-uploading">
        <progress max="1" value=${this.uploading}></progress>
        <span>${Math.round(this.uploading * 100)} %</span>
      </div>`;
    }
    return html`<div class="actions">
      <label class="file" data-testid="model-upload-label"
        ${makes(request("PUT", "/api/vision/models/model.onnx"))}>${t("vision.detector.upload")}
        <input type="file" accept=".onnx" data-testid="model-upload" @change=${(e: Event) => this.upload(e)} /></label>
    </div>`;
  }

  private set(change: Partial<Draft>): void {
    this.draft = { ...this.draft, ...change };
  }

  private value(): Record<string, unknown> {
    const d = this.draft;
    if (d.method === "aruco") {
      return { method: "aruco", camera: this.camera, dictionary: d.dictionary, marker_size: d.marker_size };
    }
    return {
      method: "neural",
      camera: this.camera,
      model: d.model,
      classes: d.classes
        .split(",")
        .map((c) => c.trim())
        .filter((c) => c),
      layout: d.layout,
      input_size: d.input_size,
      threshold: d.threshold,
      height: d.height,
    };
  }

  private async save(): Promise<void> {
    this.error = "";
    const name = this.draft.name;
    if (!NAME.test(name)) {
      this.error = t("vision.template.bad_name");
      return;
    }
    this.busy = true;
    try {
      await ok(client.PUT("/api/variables/{name}", {
        params: { path: { name: `${DETECTOR_PREFIX}${name}` } },
        body: { type: "detector", value: this.value() },
      }));
      this.dispatchEvent(new CustomEvent("saved", { detail: name, bubbles: true, composed: true }));
    } catch (err) {
      this.error = errorText(err);
    } finally {
      this.busy = false;
    }
  }

  private select(label: string, testid: string, value: string, options: string[], set: (v: string) => void) {
    return html`<label>${label}
      <select data-testid=${testid} .value=${value} @change=${(e: Event) => set((e.target as HTMLSelectElement).value)}>
        ${options.map((o) => html`<option value=${o} ?selected=${o === value}>${o}</option>`)}
      </select></label>`;
  }

  render() {
    const d = this.draft;
    return html`
      <h3>${t("vision.detector.new")}</h3>
      <div class="fields">
        <label>${t("vision.template.name")}
          <input data-testid="detector-name" .value=${d.name} autocapitalize="off"
            @input=${(e: Event) => this.set({ name: (e.target as HTMLInputElement).value.trim() })} /></label>
        <label>${t("vision.detector.method")}
          <select data-testid="detector-method" .value=${d.method}
            @change=${(e: Event) => this.set({ method: (e.target as HTMLSelectElement).value as Draft["method"] })}>
            <option value="aruco" ?selected=${d.method === "aruco"}>${t("vision.detector.aruco")}</option>
            <option value="neural" ?selected=${d.method === "neural"}>${t("vision.detector.neural")}</option>
          </select></label>
      </div>
      ${d.method === "aruco"
        ? html`<div class="fields">
            ${this.select(t("vision.board.dictionary"), "detector-dictionary", d.dictionary, DICTIONARIES, (v) => this.set({ dictionary: v }))}
            ${lengthField("vision.detector.marker_size", "detector-marker-size", d.marker_size, (v) => this.set({ marker_size: v }))}
          </div>`
        : html`${this.models.length
              ? ""
              : html`<p class="muted" data-testid="detector-no-models">${t("vision.detector.no_models")}</p>`}
            <div class="fields">
              ${this.select(t("vision.detector.model"), "detector-model", d.model, this.models, (v) => this.set({ model: v }))}
              ${this.select(t("vision.detector.layout"), "detector-layout", d.layout, ["yolov8", "yolov5"], (v) => this.set({ layout: v as Draft["layout"] }))}
              ${numberField(t("vision.detector.input_size"), "detector-input-size", d.input_size, (v) => this.set({ input_size: Math.round(v) }), "32")}
              ${numberField(t("vision.detector.threshold"), "detector-threshold", d.threshold, (v) => this.set({ threshold: v }), "0.05")}
              ${lengthField("vision.detector.height", "detector-height", d.height, (v) => this.set({ height: v }))}
            </div>
            ${this.uploadControl()}
            <label>${t("vision.detector.classes")}
              <input data-testid="detector-classes" .value=${d.classes}
                @input=${(e: Event) => this.set({ classes: (e.target as HTMLInputElement).value })} /></label>`}
      <div class="actions">
        <button class="primary" data-testid="detector-save"
          ?disabled=${this.busy || !this.camera}
          ${makes(request("PUT", `/api/variables/${DETECTOR_PREFIX}${d.name}`))}
          @click=${() => void this.save()}>${t("vision.save")}</button>
      </div>
      ${this.error ? html`<p class="error" role="alert" data-testid="detector-error">${this.error}</p>` : ""}
    `;
  }
}

customElements.define("op-detector-form", OpDetectorForm);
