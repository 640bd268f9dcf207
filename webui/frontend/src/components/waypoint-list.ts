import { LitElement, css, html } from "lit";
import { shared } from "../styles";
import "./hold-button";

export interface Waypoint {
  name: string;
  type: "joint_waypoint" | "pose_waypoint";
  tags: string[];
  doc: string;
  updated: number;
  tcp_position: [number, number, number];
}

// Taught waypoints: move to one (hold), rename, re-teach, delete. Emits events; the panel acts.
export class OpWaypointList extends LitElement {
  static properties = {
    waypoints: { attribute: false },
    disabled: { type: Boolean },
    selected: { type: String },
  };
  declare waypoints: Waypoint[];
  declare disabled: boolean;
  declare selected: string;

  static styles = [
    shared,
    css`
      .item {
        display: grid;
        grid-template-columns: 1fr auto;
        gap: 8px;
        align-items: center;
        padding: 10px 0;
        border-bottom: 1px solid var(--line);
      }
      .item.selected .name {
        color: var(--ok);
      }
      .name {
        font-weight: 700;
        overflow-wrap: anywhere;
      }
      .actions {
        display: flex;
        gap: 6px;
        flex-wrap: wrap;
        justify-content: flex-end;
      }
      .actions button {
        padding: 0 12px;
        font-size: 16px;
      }
      op-hold-button {
        width: 150px;
        height: 56px;
        display: block;
        --hold-font-size: 16px;
        --hold-min-height: 56px;
      }
      .empty {
        padding: 12px 0;
      }
    `,
  ];

  constructor() {
    super();
    this.waypoints = [];
    this.disabled = false;
    this.selected = "";
  }

  private emit(type: string, name: string) {
    this.dispatchEvent(new CustomEvent(type, { detail: { name }, bubbles: true, composed: true }));
  }

  render() {
    if (!this.waypoints.length) {
      return html`<div class="empty muted">No waypoints yet: jog the robot and save one.</div>`;
    }
    return html`${this.waypoints.map(
      (w) => html`<div
        class="item ${w.name === this.selected ? "selected" : ""}"
        data-testid="waypoint"
        data-name=${w.name}
      >
        <div>
          <div class="name">${w.name}</div>
          <div class="muted">${w.type === "joint_waypoint" ? "joints" : "pose"}${w.tags.length
            ? html` · ${w.tags.join(", ")}` : ""}</div>
        </div>
        <div class="actions">
          <op-hold-button
            data-testid="move-to"
            ?disabled=${this.disabled}
            @hold-start=${() => this.emit("waypoint-hold", w.name)}
            @hold-end=${() => this.emit("waypoint-release", w.name)}
            >Hold: move to</op-hold-button
          >
          <button data-testid="reteach" ?disabled=${this.disabled}
            @click=${() => this.emit("waypoint-reteach", w.name)}>Re-teach</button>
          <button data-testid="rename" @click=${() => this.emit("waypoint-rename", w.name)}>
            Name &amp; tags</button>
          <button class="danger" data-testid="delete"
            @click=${() => this.emit("waypoint-delete", w.name)}>Delete</button>
        </div>
      </div>`,
    )}`;
  }
}

customElements.define("op-waypoint-list", OpWaypointList);
