import { LitElement, css, html } from "lit";
import { modeLabel } from "./format";
import { FeedController, feed } from "./live";
import { shared } from "./styles";
import type { AddedDevice, RobotState } from "./types";

// Always on screen: is the runtime reachable, and for each robot its link, mode and faults.
export class OpStatusBar extends LitElement {
  static styles = [
    shared,
    css`
      :host {
        display: flex;
        align-items: center;
        gap: 12px;
        flex-wrap: wrap;
        padding: 8px 14px;
        min-height: 64px;
        background: #0b1015;
        border-bottom: 1px solid var(--line);
      }
      .brand {
        font-weight: 800;
        font-size: 20px;
        letter-spacing: 0.02em;
        margin-right: 8px;
      }
      .brand span {
        color: var(--accent);
      }
      .robots {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
        flex: 1;
      }
      .robot {
        display: flex;
        align-items: center;
        gap: 8px;
        padding: 6px 12px;
        border-radius: 10px;
        background: var(--panel);
        border: 1px solid var(--line);
        font-size: 16px;
      }
      .offline {
        background: var(--bad);
        color: white;
        font-weight: 700;
        padding: 8px 14px;
        border-radius: 10px;
      }
    `,
  ];

  constructor() {
    super();
    new FeedController(this);
  }

  private robotChip(device: AddedDevice, state: RobotState | undefined) {
    const link = device.status === "connected" ? "ok" : device.status === "connecting" ? "warn" : "bad";
    let badge = html``;
    if (state?.flags.estop) badge = html`<span class="chip bad">E-STOP</span>`;
    else if (state?.flags.error) badge = html`<span class="chip bad" title=${state.error_message}>ERROR</span>`;
    else if (state && !state.flags.enabled) badge = html`<span class="chip">Disabled</span>`;
    return html`<div class="robot" data-testid="status-robot" data-name=${device.local_name}>
      <span class="dot ${link}" title=${device.status}></span>
      <strong>${device.local_name}</strong>
      ${state
        ? html`<span class="muted">${modeLabel(state.operational_mode)}</span>`
        : html`<span class="muted">${device.status}</span>`}
      ${badge}
    </div>`;
  }

  render() {
    const robots = feed.robots();
    return html`
      <div class="brand">Open<span>Pendant</span></div>
      <div class="robots">
        ${robots.length === 0 && feed.online
          ? html`<span class="muted">No robot added</span>`
          : robots.map((d) => this.robotChip(d, feed.states.get(d.local_name)))}
      </div>
      ${feed.online
        ? html`<span class="chip ok" data-testid="runtime-link">Runtime connected</span>`
        : html`<span class="offline" data-testid="runtime-link" role="alert"
            >No connection to the runtime — retrying…</span
          >`}
    `;
  }
}

customElements.define("op-status-bar", OpStatusBar);
