import { LitElement, css, html } from "lit";
import { mm } from "../format";
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

/** A move to a waypoint under way: which, and how far the TCP still has to go. */
export interface MoveProgress {
  name: string;
  text: string;
}


// Taught waypoints of the robot in focus, with where each puts the TCP (in the robot's base
// frame): filter by name or tag, move to one (hold), rename, re-teach, delete. Emits
// events; the panel acts.
export class OpWaypointList extends LitElement {
  static properties = {
    waypoints: { attribute: false },
    disabled: { type: Boolean },
    selected: { type: String },
    progress: { attribute: false },
    filter: { state: true },
  };
  declare waypoints: Waypoint[];
  declare disabled: boolean;
  declare selected: string;
  declare progress: MoveProgress | null;
  declare filter: string;

  static styles = [
    shared,
    css`
      .item {
        display: flex;
        flex-wrap: wrap;
        gap: 8px;
        align-items: center;
        padding: 10px 0;
        border-bottom: 1px solid var(--line);
      }
      .about {
        flex: 1 1 14em; /* the name keeps its width; the buttons wrap below it instead */
        min-width: 0;
      }
      .name {
        font-weight: 700;
        overflow-wrap: anywhere;
      }
      .coords {
        font-variant-numeric: tabular-nums;
      }
      .filter {
        width: 100%;
        margin-bottom: 6px;
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
    this.progress = null;
    this.filter = "";
  }

  private shown(): Waypoint[] {
    const words = this.filter.toLowerCase().split(/\s+/).filter(Boolean);
    return this.waypoints.filter((w) => words.every((word) =>
      w.name.toLowerCase().includes(word) || w.tags.some((t) => t.toLowerCase().includes(word))));
  }

  private emit(type: string, name: string) {
    this.dispatchEvent(new CustomEvent(type, { detail: { name }, bubbles: true, composed: true }));
  }

  render() {
    if (!this.waypoints.length) {
      return html`<div class="empty muted">No waypoints yet: jog the robot and save one.</div>`;
    }
    const shown = this.shown();
    return html`<input class="filter" type="search" data-testid="waypoint-filter"
        placeholder="Filter by name or tag" aria-label="Filter waypoints by name or tag"
        .value=${this.filter}
        @input=${(e: Event) => (this.filter = (e.target as HTMLInputElement).value)} />
      ${shown.length < this.waypoints.length
        ? html`<div class="muted" data-testid="waypoint-count">
            ${shown.length} of ${this.waypoints.length} waypoints</div>` : ""}
      ${shown.map(
      (w) => html`<div
        class="item ${w.name === this.selected ? "selected" : ""}"
        data-testid="waypoint"
        data-name=${w.name}
      >
        <div class="about">
          <div class="name">${w.name}
            ${w.name === this.selected
              ? html`<span class="chip ok" title="Saved or moved to last">last used</span>` : ""}
          </div>
          <div class="muted coords" data-testid="waypoint-coords"
            title="Where the TCP goes, in the robot's base frame">
            X ${mm(w.tcp_position[0])} · Y ${mm(w.tcp_position[1])} ·
            Z ${mm(w.tcp_position[2])} mm</div>
          <div class="muted">${w.type === "joint_waypoint" ? "joints" : "pose"}${w.tags.length
            ? html` · ${w.tags.join(", ")}` : ""}</div>
          ${this.progress?.name === w.name
            ? html`<div class="chip ok" data-testid="move-progress">${this.progress.text}</div>`
            : ""}
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
