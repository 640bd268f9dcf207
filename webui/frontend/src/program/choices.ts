// What the dropdowns of the robot, I/O and waypoint blocks offer: the robots added, the
// digital inputs and outputs each has, the analog signals of the I/O blocks, the waypoints taught,
// the detectors stored. Waypoints taught, renamed or
// deleted anywhere reach them at once over the waypoint feed.

import { client, ok } from "../api";
import { feed } from "../live";
import type { RobotInfo } from "../types";
import { DETECTOR_PREFIX } from "../vision/detections";
import { type WaypointChange, WaypointFeed } from "./waypoint-feed";

export const waypointFeed = new WaypointFeed(
  (change) => void applyWaypoint(change),
  () => void refreshChoices().catch(() => undefined),
);

async function applyWaypoint({ name, present }: WaypointChange): Promise<void> {
  const { choices } = await import("./catalog");
  const names = new Set(choices.waypoints);
  if (present) names.add(name);
  else names.delete(name);
  choices.waypoints = [...names];
}

interface SignalInfo {
  name: string;
  kind: string;
}

/** The robot names and what each has, for the dropdowns of the robot and I/O blocks: a
 * robot controller's numbered I/O, and the digital signals of every I/O block by name. */
export async function refreshChoices(): Promise<void> {
  const { choices } = await import("./catalog");
  const robots = feed.robots().map((r) => r.local_name);
  choices.robots = robots;
  const withIO = feed.devices.filter((d) => d.kind === "robot" || d.kind === "io");
  const details = await Promise.all(
    withIO.map((d) =>
      ok(client.GET("/api/devices/{local_name}", { params: { path: { local_name: d.local_name } } }))
        .catch(() => null),
    ),
  );
  const inputs: string[] = [];
  const outputs: string[] = [];
  const analogs: string[] = [];
  const analogOutputs: string[] = [];
  for (const d of details) {
    // Any kind's driver info: an I/O block's names its signals, a robot's its I/O counts.
    const info = d?.info?.info as Partial<RobotInfo> | undefined;
    if (!d || !info) continue;
    if (d.kind === "io") {
      const signals = (info as unknown as { signals?: SignalInfo[] }).signals ?? [];
      for (const s of signals) {
        if (s.kind === "digital_input") inputs.push(`${d.local_name}.${s.name}`);
        if (s.kind === "digital_output") outputs.push(`${d.local_name}.${s.name}`);
        if (s.kind.startsWith("analog")) analogs.push(`${d.local_name}.${s.name}`);
        if (s.kind === "analog_output") analogOutputs.push(`${d.local_name}.${s.name}`);
      }
      continue;
    }
    for (let i = 0; i < (info.digital_inputs ?? 0); i++) inputs.push(`${d.local_name}.di${i}`);
    for (let i = 0; i < (info.digital_outputs ?? 0); i++) outputs.push(`${d.local_name}.do${i}`);
  }
  choices.inputs = inputs;
  choices.outputs = outputs;
  choices.analogs = analogs;
  choices.analog_outputs = analogOutputs;
  const lists = await Promise.all(
    ["joint_waypoint", "pose_waypoint"].map((type) =>
      ok(client.GET("/api/variables", { params: { query: { type } } })).catch(() => []),
    ),
  );
  choices.waypoints = lists.flat().map((v) => v.name);
  const detectors = await ok(
    client.GET("/api/variables", { params: { query: { type: "detector" } } }),
  ).catch(() => []);
  choices.detectors = detectors
    .filter((v) => v.name.startsWith(DETECTOR_PREFIX))
    .map((v) => v.name.slice(DETECTOR_PREFIX.length));
}
