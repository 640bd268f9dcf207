import { LitElement, css, html } from "lit";
import { client, errorText, ok } from "../api";
import { control, leaseRequest } from "../control";
import { t } from "../i18n";
import { Listening } from "../listening";
import { FeedController, feed } from "../live";
import { makes, request } from "../rights";
import { shared } from "../styles";
import { roughLength } from "../units";

interface GripperState {
  connected: boolean;
  activated: boolean;
  position: number | null;
  moving: boolean;
  object_detected: boolean;
  fault: string;
}

type Action = "activate" | "open" | "close";

// The grippers beside the jog buttons: open and close while teaching, with what each holds.
// Like a robot, a gripper is commanded only by the pendant that has control of it.
export class OpGripperCard extends LitElement {
  static properties = {
    busy: { state: true },
    error: { state: true },
  };
  declare busy: string;
  declare error: string;
  private readonly onControl = () => this.requestUpdate();

  static styles = [
    shared,
    css`
      .gripper {
        display: grid;
        gap: 8px;
        padding: 8px 0;
        border-top: 1px solid var(--line);
      }
      .gripper:first-of-type {
        border-top: none;
      }
      .row {
        display: flex;
        flex-wrap: wrap;
        align-items: center;
        gap: 8px;
      }
      .row button {
        flex: 1 1 88px;
        min-height: var(--touch);
      }
      .readout {
        font-variant-numeric: tabular-nums;
      }
      .holds {
        color: var(--ok);
        font-weight: 700;
      }
    `,
  ];

  constructor() {
    super();
    new Listening(this, control, "change", this.onControl);
    new FeedController(this);
    this.busy = "";
    this.error = "";
  }

  private async run(name: string, work: () => Promise<unknown>): Promise<void> {
    this.error = "";
    this.busy = name;
    try {
      await work();
    } catch (err) {
      this.error = errorText(err);
    } finally {
      this.busy = "";
    }
  }

  private command(name: string, action: Action): void {
    const token = control.token(name);
    void this.run(name, () =>
      ok(client.POST("/api/devices/{local_name}/call/{method}", {
        params: { path: { local_name: name, method: action }, header: { "X-Lease-Token": token } },
        body: action === "activate" ? {} : { body: {} },
      })),
    );
  }

  private reading(state: GripperState | undefined) {
    if (!state?.connected) {
      return html`<span class="muted" data-testid="gripper-reading">${state?.fault || t("gripper.disconnected")}</span>`;
    }
    const width = state.position === null ? t("io.unknown") : roughLength(state.position);
    return html`<span class="readout" data-testid="gripper-reading">
      ${t("gripper.opening", { width })}
      ${state.object_detected ? html` · <span class="holds" data-testid="gripper-holds">${t("gripper.holds")}</span>` : ""}
      ${state.fault ? html` · <span class="error">${state.fault}</span>` : ""}
    </span>`;
  }

  private commandRequest(name: string, action: Action) {
    return makes(request("POST", `/api/devices/${encodeURIComponent(name)}/call/${action}`));
  }

  private gripper(name: string, controlledBy: string | null | undefined) {
    const state = feed.states.get(name) as unknown as GripperState | undefined;
    const mine = control.holds(name);
    const idle = this.busy !== name;
    const ready = mine && idle && !!state?.connected;
    return html`<div class="gripper" data-testid="gripper" data-name=${name}
      data-holds=${String(!!state?.object_detected)}>
      <div class="row">
        <strong translate="no">${name}</strong>
        ${this.reading(state)}
      </div>
      <div class="row">
        ${mine
          ? html`
              ${state?.activated === false
                ? html`<button data-testid="gripper-activate-${name}" ?disabled=${!ready}
                    ${this.commandRequest(name, "activate")}
                    @click=${() => this.command(name, "activate")}>${t("gripper.activate")}</button>`
                : ""}
              <button data-testid="gripper-open-${name}" ?disabled=${!ready || !state?.activated}
                ${this.commandRequest(name, "open")}
                @click=${() => this.command(name, "open")}>${t("gripper.open")}</button>
              <button data-testid="gripper-close-${name}" ?disabled=${!ready || !state?.activated}
                ${this.commandRequest(name, "close")}
                @click=${() => this.command(name, "close")}>${t("gripper.close")}</button>
              <button data-testid="gripper-release-${name}" ${makes(leaseRequest(name, true))}
                @click=${() => this.run(name, () => control.release(name))}>${t("jog.control.release")}</button>`
          : html`
              <span class="muted">${controlledBy ? t("jog.control.controlled_by", { holder: controlledBy }) : ""}</span>
              <button class="primary" data-testid="gripper-control-${name}" ${makes(leaseRequest(name))}
                @click=${() => this.run(name, () => control.take(name))}>${t("jog.control.take")}</button>`}
      </div>
    </div>`;
  }

  render() {
    const grippers = feed.devices.filter((d) => d.kind === "gripper");
    if (!grippers.length) return html``;
    return html`<section class="card" data-testid="gripper-card">
      <h2>${t("gripper.title")}</h2>
      ${this.error ? html`<p class="error" role="alert" data-testid="gripper-error">${this.error}</p>` : ""}
      ${grippers.map((d) => this.gripper(d.local_name, d.controlled_by))}
    </section>`;
  }
}

customElements.define("op-gripper-card", OpGripperCard);
