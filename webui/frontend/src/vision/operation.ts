import { html, type TemplateResult } from "lit";
import { client, ok, type Schemas } from "../api";
import { t } from "../i18n";
import { makes, request } from "../rights";

// A long vision operation (a solve, a robot-origin run): followed until it ends, its
// progress and stage shown with a Cancel button; what it found is stored only on Save.

type Found = NonNullable<Schemas["OperationStatus"]["result"]>;

/** An operation's status, `result` what its kind finds: a camera calibration (intrinsic), a
 * camera's placement (extrinsic), a robot's base (robot_origin). */
export type OperationStatus<R extends Found = Found> = Omit<Schemas["OperationStatus"], "result"> & {
  result: R | null;
};

/** An operation's status as the runtime sends it, read as its kind's (see OperationStatus). */
export function asKind<R extends Found>(status: Schemas["OperationStatus"]): OperationStatus<R> {
  return status as OperationStatus<R>;
}

const POLL_MS = 250;

/** Calls `seen` with each status until the operation ends (or `wanted` says stop). */
export async function follow<R extends Found>(
  started: OperationStatus<R>,
  seen: (status: OperationStatus<R>) => void,
  wanted: () => boolean,
): Promise<OperationStatus<R>> {
  let status = started;
  seen(status);
  while (status.state === "running" && wanted()) {
    await new Promise((resolve) => window.setTimeout(resolve, POLL_MS));
    status = asKind<R>(await ok(client.GET("/api/vision/operations/{op_id}",
      { params: { path: { op_id: status.id } } })));
    if (!wanted()) break; // the step moved on while this was asked
    seen(status);
  }
  return status;
}

export function cancelOperation(id: string): Promise<unknown> {
  return ok(client.POST("/api/vision/operations/{op_id}/cancel", { params: { path: { op_id: id } } }));
}

/** On a control that saves what an operation found. */
export function savesOperation(id: string) {
  return makes(request("POST", `/api/vision/operations/${encodeURIComponent(id)}/save`));
}

export async function saveOperation(id: string): Promise<string[]> {
  const saved = await ok(client.POST("/api/vision/operations/{op_id}/save",
    { params: { path: { op_id: id } } }));
  return saved.saved;
}

/** The operation's progress bar, stage and Cancel, or how it ended. */
export function operationView(
  op: OperationStatus | null,
  cancel: () => void,
): TemplateResult | string {
  if (op === null) return "";
  if (op.state === "running") {
    return html`<div class="operation" data-testid="op-running">
      <progress max="1" value=${op.progress}></progress>
      <span>${Math.round(op.progress * 100)} % · ${op.stage}</span>
      <button class="danger" data-testid="op-cancel" @click=${cancel}
        ${makes(request("POST", `/api/vision/operations/${encodeURIComponent(op.id)}/cancel`))}>${t("vision.cancel")}</button>
    </div>`;
  }
  if (op.state === "failed") {
    return html`<p class="error" role="alert" data-testid="op-failed">${op.error}</p>`;
  }
  if (op.state === "cancelled") {
    return html`<p class="muted" data-testid="op-cancelled">${t("vision.cancelled")}</p>`;
  }
  return "";
}
