import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import type { WaypointDialog } from "../jog/teach";
import { makes, request } from "../rights";
import { shared } from "../styles";
import type { MoveProgress, Waypoint } from "./waypoint-list";
import "./modal";
import "./name-dialog";
import "./waypoint-list";

// The Jog panel's waypoints: save the robot's joints or its pose (in the base or the world
// frame) with one tap, the list of those taught (its events come through: waypoint-hold,
// -release, -rename, -delete, -reteach), and the dialogs to teach under a name, rename and
// re-tag, and delete. Emits teach-now {type, frame}, dialog-confirm {name, tags},
// dialog-delete {name} and dialog-close; the panel acts.
export class OpJogWaypoints extends LitElement {
  static properties = {
    robot: { type: String },
    waypoints: { attribute: false },
    selected: { type: String },
    canTeach: { type: Boolean },
    canMove: { type: Boolean },
    why: { type: String },
    progress: { attribute: false },
    dialog: { attribute: false },
  };
  declare robot: string;
  declare waypoints: Waypoint[];
  declare selected: string; // the waypoint last used
  declare canTeach: boolean; // the robot's state is known
  declare canMove: boolean;
  declare why: string; // why Move to cannot be held, said on a touch
  declare progress: MoveProgress | null;
  declare dialog: WaypointDialog;

  static styles = [
    shared,
    css`
      section.card {
        margin-bottom: 14px;
      }
      .row {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
        align-items: center;
      }
    `,
  ];

  constructor() {
    super();
    this.robot = "";
    this.waypoints = [];
    this.selected = "";
    this.canTeach = false;
    this.canMove = false;
    this.why = "";
    this.progress = null;
    this.dialog = null;
  }

  private emit(type: string, detail?: object): void {
    this.dispatchEvent(new CustomEvent(type, { detail }));
  }

  /** One close event, whether the sheet (Escape, the backdrop) or a Cancel button sent it. */
  private close = (e?: Event) => {
    e?.stopPropagation();
    this.emit("dialog-close");
  };

  private confirm = (e: CustomEvent<{ name: string; tags: string[] }>) => {
    this.emit("dialog-confirm", { name: e.detail.name, tags: e.detail.tags });
  };

  private teachRequest() {
    return request("POST", `/api/jog/robots/${encodeURIComponent(this.robot)}/teach`);
  }

  private renderDialog() {
    const d = this.dialog;
    if (!d) return "";
    if (d.kind === "teach") {
      const heading = d.type === "joint" ? t("jog.dialog.save_joint")
        : d.frame === "base" ? t("jog.dialog.save_pose_base") : t("jog.dialog.save_pose_world");
      return html`<op-name-dialog heading=${heading}
        .value=${d.name} .error=${d.error} .requests=${[this.teachRequest()]}
        confirmLabel=${d.overwrite ? t("jog.dialog.overwrite") : t("jog.dialog.save")}
        @close=${this.close} @confirm=${this.confirm}></op-name-dialog>`;
    }
    if (d.kind === "rename") {
      return html`<op-name-dialog heading=${t("jog.dialog.waypoint", { name: d.from })}
        .value=${d.name} tags=${d.tags.join(", ")} .error=${d.error}
        .requests=${[
          request("POST", `/api/variables/${encodeURIComponent(d.from)}/rename`),
          request("PUT", `/api/variables/${encodeURIComponent(d.name)}`),
        ]}
        confirmLabel=${t("jog.dialog.save")} @close=${this.close}
        @confirm=${this.confirm}></op-name-dialog>`;
    }
    return html`<op-modal heading=${t("jog.dialog.delete", { name: d.name })} @close=${this.close}>
      <p>${t("jog.dialog.history_kept")}</p>
      <div class="row" style="justify-content:flex-end">
        <button @click=${() => this.close()}>${t("jog.dialog.cancel")}</button>
        <button class="danger" data-testid="confirm-delete"
          ${makes(request("DELETE", `/api/variables/${encodeURIComponent(d.name)}`))}
          @click=${() => this.emit("dialog-delete", { name: d.name })}>
          ${t("jog.dialog.confirm_delete")}</button>
      </div>
    </op-modal>`;
  }

  render() {
    const teach = (type: "joint" | "pose", frame: "base" | "world") =>
      this.emit("teach-now", { type, frame });
    const teaches = makes(this.teachRequest());
    return html`<section class="card">
        <h2>${t("jog.waypoints")}</h2>
        <div class="row" style="margin-bottom:8px">
          <button data-testid="teach-joint" ?disabled=${!this.canTeach} ${teaches}
            @click=${() => teach("joint", "base")}>${t("jog.save_joints")}</button>
          <button data-testid="teach-pose" ?disabled=${!this.canTeach} ${teaches}
            @click=${() => teach("pose", "base")}>${t("jog.save_pose_base")}</button>
          <button data-testid="teach-pose-world" ?disabled=${!this.canTeach} ${teaches}
            @click=${() => teach("pose", "world")}>
            ${t("jog.save_pose_world")}</button>
        </div>
        <op-waypoint-list robot=${this.robot} .waypoints=${this.waypoints} ?disabled=${!this.canMove}
          why=${this.why} .progress=${this.progress} selected=${this.selected}></op-waypoint-list>
      </section>
      ${this.renderDialog()}`;
  }
}

customElements.define("op-jog-waypoints", OpJogWaypoints);
