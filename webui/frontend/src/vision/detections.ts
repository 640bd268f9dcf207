import { html } from "lit";
import { client, ok, type Schemas } from "../api";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { lengthWithUnit } from "../units";
import type { Overlay } from "./camera-view";

// Detecting with a stored detector (`detectors.<name>`), and what the answer shows: boxes
// laid over the picture, and a list of what was found with its place in the world.

export type Found = Schemas["Located"];
export type Detections = Schemas["LocatedDetections"];

export const DETECTOR_PREFIX = "detectors.";

export async function detectorsOf(camera: string): Promise<string[]> {
  const all = await ok(client.GET("/api/variables", { params: { query: { type: "detector" } } }));
  return all
    .filter((v) => v.name.startsWith(DETECTOR_PREFIX)
      && (v.value as { camera?: unknown } | null)?.camera === camera)
    .map((v) => v.name.slice(DETECTOR_PREFIX.length))
    .sort();
}

export function detect(name: string): Promise<Detections> {
  return ok(client.POST("/api/vision/detectors/{name}/detect",
    { params: { path: { name } }, body: {} }));
}

/** On a control that detects with a detector (none chosen yet: nothing to declare). */
export function detects(name: string) {
  return makes(...(name
    ? [request("POST", `/api/vision/detectors/${encodeURIComponent(name)}/detect`)] : []));
}

export function overlayOf(found: Detections | null): Overlay {
  return {
    boxes: (found?.detections ?? []).map((d) => ({
      ...d.box,
      label: `${d.label} ${Math.round(d.confidence * 100)} %`,
    })),
  };
}

function where(d: Found) {
  const pose = d.world_pose ?? d.pose;
  if (!pose) return t("vision.detect.no_pose");
  const [x, y, z] = pose.position;
  const frame = d.world_pose ? t("vision.detect.world") : t("vision.detect.camera_frame");
  return `${frame}: x ${lengthWithUnit(x)}, y ${lengthWithUnit(y)}, z ${lengthWithUnit(z)}`;
}

export function detectionList(found: Detections | null) {
  if (!found) return "";
  return html`<p class="muted" data-testid="detect-summary" data-count=${found.detections.length}>
      ${t("vision.detect.found", { count: found.detections.length, age: Math.round(found.age * 1000) })}
      ${found.placed ? "" : found.calibrated ? t("vision.detect.not_placed") : t("vision.detect.not_calibrated")}
    </p>
    <ul class="rows" data-testid="detections">
      ${found.detections.map(
        (d) => html`<li data-label=${d.label}>
          <strong translate="no">${d.label}</strong>
          <span>${Math.round(d.confidence * 100)} %</span>
          <span>${where(d)}</span>
        </li>`,
      )}
    </ul>`;
}
