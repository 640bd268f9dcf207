// The robots a 3D view draws: every robot of the device list, each with its model (URDF,
// links, joints). The robot in focus comes from the panel, which asks for it anyway; the
// others are asked for here, once per device (again a moment after a failure). A robot
// removed, or whose name now stands for another device, is forgotten.

import { client, ok } from "../api";
import { focus } from "../focus";
import { feed } from "../live";
import type { RobotModel } from "./robot-view";

// A robot whose model could not be had is asked for again this much later.
const RETRY_MS = 1000;

export class CellModels {
  private models = new Map<string, RobotModel>(); // by robot
  private uuids = new Map<string, string>(); // the device each model was had for
  private fetching = new Set<string>();
  private failed = new Map<string, number>(); // when a robot's model could not be had
  private round = 0;

  /** `changed` is told when a model came. */
  constructor(private readonly changed: () => void) {}

  get(name: string): RobotModel | undefined {
    return this.models.get(name);
  }

  entries(): [string, RobotModel][] {
    return [...this.models];
  }

  /** A model as the panel gives it. */
  give(model: RobotModel): void {
    this.models.set(model.name, model);
    const device = feed.robots().find((d) => d.local_name === model.name);
    this.uuids.set(model.name, device?.uuid ?? "");
  }

  /** In step with the device list: missing models asked for; the robots forgotten. */
  follow(): string[] {
    const devices = new Map(feed.robots().map((d) => [d.local_name, d]));
    const gone: string[] = [];
    for (const name of [...this.models.keys()]) {
      const device = devices.get(name);
      const uuid = this.uuids.get(name);
      if (device && (!uuid || uuid === device.uuid)) continue;
      this.models.delete(name);
      this.uuids.delete(name);
      gone.push(name);
    }
    for (const [name, device] of devices) {
      if (this.models.has(name) || name === focus.robot || device.status !== "connected") continue;
      const failed = this.failed.get(name);
      const due = failed === undefined || performance.now() - failed > RETRY_MS;
      if (due && !this.fetching.has(name)) void this.loadModel(name, device.uuid);
    }
    return gone;
  }

  /** Nothing under way is kept (the view left the page). */
  stop(): void {
    this.round++;
    this.fetching.clear();
  }

  private async loadModel(name: string, uuid: string): Promise<void> {
    const round = this.round;
    this.fetching.add(name);
    try {
      const model = await ok(client.GET("/api/jog/robots/{robot}", { params: { path: { robot: name } } }));
      if (round !== this.round) return;
      this.failed.delete(name);
      const listed = feed.robots().find((d) => d.local_name === name)?.uuid === uuid;
      if (listed && !this.models.has(name)) {
        this.models.set(name, model);
        this.uuids.set(name, uuid);
      }
    } catch {
      if (round === this.round) this.failed.set(name, performance.now());
    } finally {
      if (round === this.round) this.fetching.delete(name);
    }
    if (round === this.round) this.changed(); // not to a view that has left the page
  }
}
