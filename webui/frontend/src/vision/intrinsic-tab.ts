import { html } from "lit";
import { client, errorText, ok, type Schemas } from "../api";
import { type StringKey, t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
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

// The guided intrinsic calibration: the board as printed (remembered as `vision.board`),
// captures that are kept or refused with the reason, the coverage map laid over the live
// picture with what to show next, the frames with their errors (any dropped), the solve with
// its progress and cancel, the result's quality, and Save (`calibration.<camera>`).

export type BoardSpec = Schemas["BoardSpec"];
type Advice = Schemas["Advice"];
type SessionView = Schemas["IntrinsicSessionView"];
type FrameReport = Schemas["FrameReport"];
type Calibration = Schemas["CameraCalibration"];

const DEFAULT_BOARD: BoardSpec = {
  kind: "charuco",
  squares_x: 9,
  squares_y: 6,
  square: 0.03,
  marker: 0.022,
  dictionary: "5x5_100",
};
export const DICTIONARIES = ["4x4_50", "4x4_100", "5x5_100", "5x5_250", "6x6_250", "7x7_1000"];
const MIN_SOLVE = 4;
const TILTS = ["flat", "left", "right", "up", "down"];

export class OpIntrinsicTab extends VisionStep {
  static properties = {
    camera: { type: String },
    board: { state: true },
    view: { state: true },
    report: { state: true },
    op: { state: true },
    saved: { state: true },
  };
  declare camera: string;
  declare board: BoardSpec;
  declare view: SessionView | null;
  declare report: FrameReport | null;
  declare op: OperationStatus<Calibration> | null;
  declare saved: string;

  private edited = false; // the stored board, read late, must not undo what was typed

  static styles = [shared, visionStyles];

  constructor() {
    super();
    this.camera = "";
    this.board = { ...DEFAULT_BOARD };
    this.view = null;
    this.report = null;
    this.op = null;
    this.saved = "";
  }

  connectedCallback(): void {
    super.connectedCallback();
    void this.loadBoard();
  }

  protected willUpdate(changed: Map<string, unknown>): void {
    // A session is one camera's: another camera chosen starts from the board again.
    if (changed.has("camera") && this.view && this.view.camera !== this.camera) this.reset();
  }

  private async loadBoard(): Promise<void> {
    try {
      const stored = await ok(client.GET("/api/variables",
        { params: { query: { type: "calibration_board" } } }));
      const setting = stored.find((v) => v.name === "vision.board");
      // None stored yet: the usual board's numbers to start from.
      if (setting && !this.edited) {
        this.board = { ...DEFAULT_BOARD, ...(setting.value as Partial<BoardSpec>) };
      }
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private showOverlay(): void {
    const view = this.view;
    if (!view) return this.emitOverlay({});
    this.emitOverlay({ coverage: view.coverage, points: this.report?.accepted ? this.report.points : [] });
  }

  private path(): string {
    return `/api/vision/intrinsic/${encodeURIComponent(this.view!.id)}`;
  }

  private sessionId() {
    return { params: { path: { session_id: this.view!.id } } };
  }

  private start(): Promise<void> {
    return this.act(async () => {
      this.view = await ok(client.POST("/api/vision/intrinsic",
        { body: { camera: this.camera, board: this.board } }));
      this.report = null;
      this.op = null;
      this.saved = "";
      this.showOverlay();
    });
  }

  private capture(): Promise<void> {
    return this.act(async () => {
      this.report = await ok(client.POST("/api/vision/intrinsic/{session_id}/capture", this.sessionId()));
      this.view = await ok(client.GET("/api/vision/intrinsic/{session_id}", this.sessionId()));
      this.showOverlay();
    });
  }

  private drop(index: number): Promise<void> {
    return this.act(async () => {
      this.view = await ok(client.DELETE("/api/vision/intrinsic/{session_id}/frames/{index}",
        { params: { path: { session_id: this.view!.id, index } } }));
      this.report = null;
      this.showOverlay();
    });
  }

  private solve(): Promise<void> {
    return this.act(async () => {
      this.saved = "";
      const started = asKind<Calibration>(
        await ok(client.POST("/api/vision/intrinsic/{session_id}/solve", this.sessionId())));
      const id = this.view!.id;
      const ended = await follow(started, (s) => (this.op = s), () => this.view?.id === id);
      if (ended.state === "done") {
        this.view = await ok(client.GET("/api/vision/intrinsic/{session_id}", this.sessionId()));
      }
      this.showOverlay();
    });
  }

  private save(): Promise<void> {
    return this.act(async () => {
      const saved = await saveOperation(this.op!.id);
      this.saved = saved.join(", ");
      this.dispatchEvent(new CustomEvent("calibrated", { bubbles: true, composed: true }));
    });
  }

  private setBoard(field: keyof BoardSpec, raw: string, scale = 1): void {
    this.edited = true;
    if (field === "kind" || field === "dictionary") {
      this.board = { ...this.board, [field]: raw };
      return;
    }
    const value = Number(raw);
    if (raw.trim() !== "" && Number.isFinite(value)) this.board = { ...this.board, [field]: value / scale };
  }

  private number(field: keyof BoardSpec, key: StringKey, scale = 1, step = "1") {
    const value = this.board[field] as number;
    return html`<label
      >${t(key)}
      <input type="number" inputmode="decimal" step=${step} data-testid="board-${field}"
        .value=${String(Math.round(value * scale * 100) / 100)}
        @change=${(e: Event) => this.setBoard(field, (e.target as HTMLInputElement).value, scale)}
    /></label>`;
  }

  private boardSummary() {
    const b = this.board;
    const size = b.kind === "charuco"
      ? `${b.squares_x} × ${b.squares_y}, ${b.square * 1000} / ${b.marker * 1000} mm, ${b.dictionary}`
      : `${b.squares_x} × ${b.squares_y}, ${b.square * 1000} mm`;
    return html`<div class="actions">
      <span data-testid="board-summary">${t("vision.board")}: ${size}</span>
      <button data-testid="intrinsic-new" ?disabled=${this.busy || this.op?.state === "running"}
        @click=${() => this.reset()}>${t("vision.intrinsic.restart")}</button>
    </div>`;
  }

  private reset(): void {
    this.view = null;
    this.report = null;
    this.op = null;
    this.saved = "";
    this.showOverlay();
  }

  private boardForm() {
    if (this.view) return this.boardSummary();
    const charuco = this.board.kind === "charuco";
    return html`<h3>${t("vision.board")}</h3>
      <div class="fields">
        <label
          >${t("vision.board.kind")}
          <select data-testid="board-kind" .value=${this.board.kind}
            @change=${(e: Event) => this.setBoard("kind", (e.target as HTMLSelectElement).value)}>
            <option value="charuco">ChArUco</option>
            <option value="chessboard">${t("vision.board.chessboard")}</option>
          </select></label
        >
        ${this.number("squares_x", "vision.board.squares_x")}
        ${this.number("squares_y", "vision.board.squares_y")}
        ${this.number("square", "vision.board.square", 1000, "0.1")}
        ${charuco ? this.number("marker", "vision.board.marker", 1000, "0.1") : ""}
        ${charuco
          ? html`<label
              >${t("vision.board.dictionary")}
              <select data-testid="board-dictionary" .value=${this.board.dictionary}
                @change=${(e: Event) => this.setBoard("dictionary", (e.target as HTMLSelectElement).value)}>
                ${DICTIONARIES.map((d) => html`<option value=${d} ?selected=${d === this.board.dictionary}>${d}</option>`)}
              </select></label
            >`
          : ""}
      </div>
      <div class="actions">
        <button class="primary" data-testid="intrinsic-start"
          ?disabled=${this.busy || !this.camera}
          ${makes(request("POST", "/api/vision/intrinsic"))}
          @click=${() => this.start()}>${t("vision.intrinsic.start")}</button>
      </div>`;
  }

  private advice(a: Advice): string {
    if (a.code === "show") {
      const region = `vision.region.${a.region.replaceAll(" ", "_")}` as StringKey;
      return t("vision.hint.show", { region: t(region) ?? a.region });
    }
    if (a.code === "more") return t("vision.hint.more", { count: a.count });
    return t(a.code === "tilt" ? "vision.hint.tilt" : "vision.hint.start");
  }

  private reportLine() {
    const r = this.report;
    if (!r) return "";
    return r.accepted
      ? html`<p class="chip ok" data-testid="capture-report" data-accepted="true">
          ${t("vision.intrinsic.kept", { index: (r.index ?? 0) + 1, corners: r.corners })}</p>`
      : html`<p class="chip warn" data-testid="capture-report" data-accepted="false">
          ${t("vision.intrinsic.refused", { reason: r.reason })}</p>`;
  }

  private session(view: SessionView) {
    const c = view.coverage;
    const solving = this.op?.state === "running";
    return html`<h3>${t("vision.intrinsic.frames", { count: view.frames.length, min: view.min_frames })}</h3>
      <div class="actions">
        <button class="primary" data-testid="intrinsic-capture" ?disabled=${this.busy || solving}
          ${makes(request("POST", `${this.path()}/capture`))}
          @click=${() => this.capture()}>${t("vision.intrinsic.capture")}</button>
        <button data-testid="intrinsic-solve" class=${c.ready ? "primary" : ""}
          ?disabled=${this.busy || solving || view.frames.length < MIN_SOLVE}
          ${makes(request("POST", `${this.path()}/solve`))}
          @click=${() => this.solve()}>${t("vision.intrinsic.solve")}</button>
      </div>
      ${this.reportLine()}
      <div class="chips">
        <span class="chip ${c.ready ? "ok" : "warn"}" data-testid="intrinsic-coverage" data-ready=${c.ready}>
          ${t("vision.intrinsic.covered", { percent: Math.round(c.covered * 100) })}</span>
        ${TILTS.map((tilt) => html`<span class="chip ${c.tilts[tilt] ? "ok" : ""}"
          >${t(`vision.tilt.${tilt}` as StringKey)} ${c.tilts[tilt] ?? 0}</span>`)}
      </div>
      <ul class="hints" data-testid="intrinsic-hints">
        ${c.advice.map((a) => html`<li>${this.advice(a)}</li>`)}
      </ul>
      <ul class="rows" data-testid="intrinsic-frames">
        ${view.frames.map(
          (f) => html`<li data-testid="frame-${f.index}" data-outlier=${f.outlier}>
            <span>#${f.index + 1} · ${t("vision.intrinsic.corners", { count: f.corners })} ·
              ${t(`vision.tilt.${f.tilt}` as StringKey)}${f.error === null ? "" : ` · ${f.error.toFixed(2)} px`}
              ${f.outlier ? html` · <strong>${t("vision.intrinsic.left_out")}</strong>` : ""}</span>
            <button data-testid="frame-drop-${f.index}" ?disabled=${this.busy || solving}
              ${makes(request("DELETE", `${this.path()}/frames/${f.index}`))}
              @click=${() => this.drop(f.index)}>${t("vision.intrinsic.drop")}</button>
          </li>`,
        )}
      </ul>`;
  }

  private result() {
    const op = this.op;
    if (op?.state !== "done" || !op.result) return "";
    const r = op.result;
    const u = r.uncertainty;
    const i = r.intrinsics;
    const pm = (name: string) => (u[name] === undefined ? "" : ` ± ${u[name].toFixed(2)}`);
    const good = r.rms <= 0.5;
    return html`<section data-testid="intrinsic-result">
      <h3>${t("vision.result")}</h3>
      <dl class="quality">
        <dt>${t("vision.intrinsic.rms")}</dt>
        <dd><span class="chip ${good ? "ok" : "warn"}" data-testid="intrinsic-rms">${r.rms.toFixed(3)} px</span>
          ${good ? "" : t("vision.intrinsic.rms_high")}</dd>
        <dt>f<sub>x</sub>, f<sub>y</sub></dt>
        <dd>${i.fx.toFixed(1)}${pm("fx")}, ${i.fy.toFixed(1)}${pm("fy")} px</dd>
        <dt>c<sub>x</sub>, c<sub>y</sub></dt>
        <dd>${i.cx.toFixed(1)}${pm("cx")}, ${i.cy.toFixed(1)}${pm("cy")} px</dd>
        <dt>k<sub>1</sub>, k<sub>2</sub></dt>
        <dd>${i.distortion.slice(0, 2).map((k) => k.toFixed(4)).join(", ")}</dd>
      </dl>
      <div class="actions">
        <button class="primary" data-testid="intrinsic-save" ?disabled=${this.busy || this.saved !== ""}
          ${savesOperation(op.id)}
          @click=${() => this.save()}>${t("vision.save")}</button>
      </div>
      ${this.saved ? html`<p class="chip ok" data-testid="intrinsic-saved">${t("vision.saved", { names: this.saved })}</p>` : ""}
    </section>`;
  }

  render() {
    return html`
      ${this.boardForm()}
      ${this.view ? this.session(this.view) : html`<p class="muted">${t("vision.intrinsic.intro")}</p>`}
      ${operationView(this.op, () => void cancelOperation(this.op!.id).catch((e) => (this.error = errorText(e))))}
      ${this.result()}
      ${this.error ? html`<p class="error" role="alert" data-testid="intrinsic-error">${this.error}</p>` : ""}
    `;
  }
}

customElements.define("op-intrinsic-tab", OpIntrinsicTab);
