import { html } from "lit";
import { api } from "../api";
import { t } from "../i18n";
import { makes, request } from "../rights";
import type { Pose } from "../types";
import { lengthWithUnit } from "../units";
import type { Overlay } from "./camera-view";

// Detecting with a stored detector (`detectors.<name>`), and what the answer shows: boxes
// laid over the picture, and a list of what was found with its place in the world.

export interface Found {
  label: string;
  confidence: number;
  box: { x: number; y: number; width: number; height: number };
  pose: Pose | null;
  world_pose: Pose | null;
}

export interface Detections {
  ts: number;
  age: number;
  detector: string;
  camera: string;
  calibrated: boolean;
  placed: boolean;
  detections: Found[];
}

export interface DetectorVariable {
  name: string;
  value: { method: string; camera: string; label?: string };
}

export const DETECTOR_PREFIX = "detectors.";

export async function detectorsOf(camera: string): Promise<string[]> {
  const all = await api<DetectorVariable[]>("GET", "/api/variables?type=detector");
  return all
    .filter((v) => v.name.startsWith(DETECTOR_PREFIX) && v.value.camera === camera)
    .map((v) => v.name.slice(DETECTOR_PREFIX.length))
    .sort();
}

export function detect(name: string): Promise<Detections> {
  return api<Detections>("POST", `/api/vision/detectors/${encodeURIComponent(name)}/detect`, {});
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
