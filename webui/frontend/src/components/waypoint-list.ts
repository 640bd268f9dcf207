import { LitElement, css, html } from "lit";
import type { Schemas } from "../api";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
import { length, lengthUnit } from "../units";
import "./hold-button";

export type Waypoint = Schemas["Waypoint"];

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
    robot: { type: String },
    waypoints: { attribute: false },
    disabled: { type: Boolean },
    why: { type: String },
    selected: { type: String },
    progress: { attribute: false },
    filter: { state: true },
  };
  declare robot: string; // whose waypoints
  declare waypoints: Waypoint[];
  declare disabled: boolean;
  declare why: string; // why Move to is disabled, said on a touch
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
    this.robot = "";
    this.waypoints = [];
    this.disabled = false;
    this.why = "";
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
      return html`<div class="empty muted">${t("scene.waypoints.none")}</div>`;
    }
    const shown = this.shown();
    const count = t("scene.waypoints.count", { shown: shown.length, total: this.waypoints.length });
    const teaches = makes(request("POST", `/api/jog/robots/${encodeURIComponent(this.robot)}/teach`));
    return html`<input class="filter" type="search" data-testid="waypoint-filter"
        placeholder=${t("scene.waypoints.filter")}
        aria-label=${t("scene.waypoints.filter_label")}
        .value=${this.filter}
        @input=${(e: Event) => (this.filter = (e.target as HTMLInputElement).value)} />
      ${shown.length < this.waypoints.length
        ? html`<div class="muted" data-testid="waypoint-count">
            ${count}</div>` : ""}
      ${shown.map(
      (w) => html`<div
        class="item ${w.name === this.selected ? "selected" : ""}"
        data-testid="waypoint"
        data-name=${w.name}
      >
        <div class="about">
          <div class="name">${w.name}
            ${w.name === this.selected
              ? html`<span class="chip ok" title=${t("scene.waypoints.last_used_title")}
                  >${t("scene.waypoints.last_used")}</span>` : ""}
          </div>
          <div class="muted coords" data-testid="waypoint-coords"
            title=${t("scene.waypoints.coords_title")}>
            X ${length(w.tcp_position[0])} · Y ${length(w.tcp_position[1])} ·
            Z ${length(w.tcp_position[2])} ${lengthUnit()}</div>
          <div class="muted">${w.type === "joint_waypoint"
            ? t("scene.waypoints.joints") : t("scene.waypoints.pose")}${w.tags.length
            ? html` · ${w.tags.join(", ")}` : ""}</div>
          ${this.progress?.name === w.name
            ? html`<div class="chip ok" data-testid="move-progress">${this.progress.text}</div>`
            : ""}
        </div>
        <div class="actions">
          <op-hold-button
            data-testid="move-to"
            ${makes(request("WS", "/api/jog/ws"))}
            ?disabled=${this.disabled}
            why=${this.why}
            @hold-start=${() => this.emit("waypoint-hold", w.name)}
            @hold-end=${() => this.emit("waypoint-release", w.name)}
            >${t("scene.waypoints.move_to")}</op-hold-button
          >
          <button data-testid="reteach" ?disabled=${this.disabled} ${teaches}
            @click=${() => this.emit("waypoint-reteach", w.name)}
            >${t("scene.waypoints.reteach")}</button>
          <button data-testid="rename" @click=${() => this.emit("waypoint-rename", w.name)}
            ${makes(request("POST", `/api/variables/${encodeURIComponent(w.name)}/rename`))}>
            ${t("scene.waypoints.rename")}</button>
          <button class="danger" data-testid="delete"
            ${makes(request("DELETE", `/api/variables/${encodeURIComponent(w.name)}`))}
            @click=${() => this.emit("waypoint-delete", w.name)}>${t("scene.delete")}</button>
        </div>
      </div>`,
    )}`;
  }
}

customElements.define("op-waypoint-list", OpWaypointList);
