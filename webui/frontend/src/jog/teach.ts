// Teaching on the Jog panel: the waypoints of the robot in focus, saved here with one tap
// (under the next free name) or through a dialog (a name of one's own, re-teaching one),
// renamed and re-tagged, deleted. What they show goes on the panel: the list, the one last
// used, the dialog and the message line.

import { ApiError, client, errorText, ok } from "../api";
import { t } from "../i18n";
import type { Waypoint } from "../components/waypoint-list";

export type WaypointDialog =
  | { kind: "teach"; type: "joint" | "pose"; frame: "base" | "world"; name: string;
      error: string; overwrite: boolean }
  | { kind: "rename"; from: string; name: string; tags: string[]; error: string }
  | { kind: "delete"; name: string }
  | null;

/** The panel's state these change. */
export interface TeachView {
  readonly robot: string;
  waypoints: Waypoint[];
  selected: string;
  message: string;
  dialog: WaypointDialog;
}

export class Teaching {
  constructor(private readonly view: TeachView) {}

  async load(): Promise<boolean> {
    try {
      this.view.waypoints = await ok(client.GET("/api/jog/robots/{robot}/waypoints",
        { params: { path: { robot: this.view.robot } } }));
      return true;
    } catch (err) {
      this.view.message = errorText(err);
      return false;
    }
  }

  private nextName(): string {
    const taken = new Set(this.view.waypoints.map((w) => w.name));
    for (let i = 1; ; i++) {
      const name = `wp_${String(i).padStart(3, "0")}`;
      if (!taken.has(name)) return name;
    }
  }

  /** One tap: saved at once under the next free name (rename it from the list). */
  async quickTeach(type: "joint" | "pose", frame: "base" | "world"): Promise<void> {
    const view = this.view;
    const name = this.nextName();
    try {
      await ok(client.POST("/api/jog/robots/{robot}/teach",
        { params: { path: { robot: view.robot } }, body: { name, kind: type, frame } }));
      view.selected = name;
      view.message = t("jog.saved", { name });
      await this.load();
    } catch (err) {
      view.message = errorText(err);
    }
  }

  /** Re-teach: the teach dialog, asking to overwrite the waypoint. */
  reteach(name: string): void {
    const waypoint = this.view.waypoints.find((w) => w.name === name);
    if (!waypoint) return;
    this.view.dialog = { kind: "teach", type: waypoint.type === "joint_waypoint" ? "joint" : "pose",
      frame: "base", name, error: t("jog.overwrite_confirm", { name }),
      overwrite: true };
  }

  renaming(name: string): void {
    const tags = this.view.waypoints.find((w) => w.name === name)?.tags ?? [];
    this.view.dialog = { kind: "rename", from: name, name, tags, error: "" };
  }

  /** The dialog's name (and tags) confirmed. */
  async confirm(name: string, tags: string[]): Promise<void> {
    const d = this.view.dialog;
    if (d?.kind === "teach") {
      this.view.dialog = { ...d, name, overwrite: d.overwrite && name === d.name };
      await this.teach();
    } else if (d?.kind === "rename") {
      this.view.dialog = { ...d, name, tags };
      await this.rename();
    }
  }

  private async teach(): Promise<void> {
    const view = this.view;
    const d = view.dialog;
    if (d?.kind !== "teach") return;
    try {
      await ok(client.POST("/api/jog/robots/{robot}/teach", {
        params: { path: { robot: view.robot } },
        body: { name: d.name, kind: d.type, frame: d.frame, overwrite: d.overwrite },
      }));
      view.dialog = null;
      view.selected = d.name;
      view.message = t("jog.saved", { name: d.name });
      await this.load();
    } catch (err) {
      const exists = err instanceof ApiError && err.code === "exists";
      view.dialog = { ...d, overwrite: exists, error: exists
        ? t("jog.exists_overwrite", { name: d.name }) : errorText(err) };
    }
  }

  private async rename(): Promise<void> {
    const view = this.view;
    const d = view.dialog;
    if (d?.kind !== "rename") return;
    try {
      if (d.name !== d.from) {
        await ok(client.POST("/api/variables/{name}/rename",
          { params: { path: { name: d.from } }, body: { to: d.name } }));
      }
      const variable = { params: { path: { name: d.name } } };
      const current = await ok(client.GET("/api/variables/{name}", variable));
      if (current.tags.join(",") !== d.tags.join(",")) {
        await ok(client.PUT("/api/variables/{name}", { ...variable, body: {
          type: current.type, value: current.value, tags: d.tags,
          expected_version: current.version } }));
      }
      view.dialog = null;
      view.selected = d.name;
      await this.load();
    } catch (err) {
      view.dialog = { ...d, error: errorText(err) };
    }
  }

  async remove(name: string): Promise<void> {
    try {
      await ok(client.DELETE("/api/variables/{name}", { params: { path: { name } } }));
    } catch (err) {
      this.view.message = errorText(err);
    }
    this.view.dialog = null;
    await this.load();
  }
}
