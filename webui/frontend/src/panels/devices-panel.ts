import { LitElement, css, html } from "lit";
import { client, errorText, ok } from "../api";
import { suggestLocalName, withBold } from "../format";
import { type StringKey, t } from "../i18n";
import { FeedController, feed } from "../live";
import { makes, request } from "../rights";
import { shared } from "../styles";
import type { AddedDevice, ConnectionStatus, DetectedDevice } from "../types";
import "../components/add-device-dialog";
import "../components/device-details";
import "../components/modal";
import "../components/robot-live";

type Dialog =
  | { kind: "add"; device: DetectedDevice | null; url: string }
  | { kind: "remove"; device: AddedDevice }
  | { kind: "repoint"; device: AddedDevice; url: string }
  | { kind: "details"; name: string }
  | null;

const STATUS: Record<ConnectionStatus, StringKey> = {
  connected: "devices.status.connected",
  connecting: "devices.status.connecting",
  stale: "devices.status.stale",
  disconnected: "devices.status.disconnected",
};

// Devices found on the network, devices added to this cell, and adding and removing them.
export class OpDevicesPanel extends LitElement {
  static properties = {
    dialog: { state: true },
    url: { state: true },
    error: { state: true },
  };
  declare dialog: Dialog;
  declare url: string;
  declare error: string;

  static styles = [
    shared,
    css`
      section {
        margin-bottom: 24px;
      }
      .grid {
        display: grid;
        grid-template-columns: repeat(auto-fill, minmax(min(340px, 100%), 1fr));
        gap: 12px;
      }
      .head {
        display: flex;
        align-items: center;
        gap: 10px;
        margin-bottom: 8px;
        flex-wrap: wrap;
      }
      .title {
        font-size: 20px;
        font-weight: 700;
        overflow-wrap: anywhere;
      }
      .sub {
        font-size: 15px;
        overflow-wrap: anywhere;
      }
      .row {
        display: flex;
        gap: 10px;
        margin-top: 12px;
        flex-wrap: wrap;
        align-items: center;
      }
      .spacer {
        flex: 1;
      }
      form.by-url {
        display: flex;
        gap: 10px;
        max-width: 640px;
      }
      .empty {
        padding: 20px;
      }
      .warn-text {
        color: var(--warn);
        font-weight: 600;
      }
      .mark {
        display: flex;
        align-items: center;
        min-height: 44px;
        margin-top: 10px;
        padding: 6px 14px;
        border-radius: 10px;
        font-size: 16px;
        font-weight: 600;
        background: var(--raised);
        overflow-wrap: anywhere;
      }
      .mark.ok {
        background: var(--ok-bg);
        color: var(--ok-fg);
      }
      .mark.warn {
        background: var(--warn-bg);
        color: var(--warn-fg);
      }
    `,
  ];

  constructor() {
    super();
    new FeedController(this);
    this.dialog = null;
    this.url = "";
    this.error = "";
  }


  private suggestion(kind: string): string {
    return suggestLocalName(kind, new Set(feed.devices.map((d) => d.local_name)));
  }

  private async removeDevice(device: AddedDevice) {
    try {
      await ok(client.DELETE("/api/devices/{local_name}",
        { params: { path: { local_name: device.local_name } } }));
      this.dialog = null;
    } catch (err) {
      this.error = errorText(err);
      this.dialog = null;
    }
  }

  private async repoint(device: AddedDevice, url: string) {
    try {
      await ok(client.PUT("/api/devices/{local_name}/address",
        { params: { path: { local_name: device.local_name } }, body: { url } }));
      this.dialog = null;
    } catch (err) {
      this.error = errorText(err);
      this.dialog = null;
    }
  }

  private statusChip(device: AddedDevice) {
    const cls = device.status === "connected" ? "ok" : device.status === "connecting" ? "warn" : "bad";
    const label = t(STATUS[device.status]);
    return html`<span class="chip ${cls}" data-testid="device-status" title=${device.last_error}
      >${label}</span
    >`;
  }

  private detectedCard(d: DetectedDevice) {
    return html`<div class="card" data-testid="detected-device" data-uuid=${d.uuid} data-mark=${d.mark}>
      <div class="head">
        <span class="title" translate=${d.name ? "no" : "yes"}
          >${d.name || t("devices.unnamed")}</span>
        <span class="chip">${d.kind}</span>
      </div>
      <div class="sub muted" translate="no">${d.model} · ${d.address}</div>
      ${d.also_at.length
        ? html`<div class="chip warn" data-testid="detected-also-at">
            ${t("devices.also_at", { urls: d.also_at.join(", ") })}</div>`
        : ""}
      ${this.detectedMark(d)}
      <div class="row">
        ${d.added_as
          ? html`<span class="chip ok">${t("devices.added_as", { name: d.added_as })}</span>`
          : html`<button
              class=${d.mark === "elsewhere" ? "" : "primary"}
              data-testid="add-device"
              ${makes(request("POST", "/api/devices"))}
              @click=${() => (this.dialog = { kind: "add", device: d, url: "" })}
            >
              ${t(d.mark === "elsewhere" ? "devices.add_anyway" : "devices.add")}
            </button>`}
      </div>
    </div>`;
  }

  // Whose the device is, as this runtime sees it: what an Add will do, said before the tap.
  private detectedMark(d: DetectedDevice) {
    if (d.mark === "added") return "";
    const elsewhere = d.mark === "elsewhere";
    const key: StringKey = elsewhere
      ? d.elsewhere === "other_key"
        ? "devices.mark.other_key"
        : "devices.mark.other_runtime"
      : d.mark === "paired"
        ? "devices.mark.paired"
        : "devices.mark.new";
    return html`<div
      class="mark ${elsewhere ? "warn" : d.mark === "paired" ? "ok" : ""}"
      data-testid="detected-mark"
      role=${elsewhere ? "note" : "status"}
    >
      ${t(key)}
    </div>`;
  }

  private addedCard(d: AddedDevice) {
    const state = feed.states.get(d.local_name);
    return html`<div class="card" data-testid="device-card" data-name=${d.local_name}>
      <div class="head">
        <span class="title" translate="no">${d.local_name}</span>
        ${this.statusChip(d)}
      </div>
      <div class="sub muted" translate="no">${d.name} · ${d.model} · ${d.url}</div>
      ${d.status !== "connected" && d.last_error
        ? html`<div class="sub error">${d.last_error}</div>`
        : ""}
      ${this.deviceSays(d)}
      ${this.claimNotice(d)}
      ${d.kind === "robot" && d.status === "connected"
        ? html`<div class="row"><op-robot-live .state=${state}></op-robot-live></div>`
        : ""}
      <div class="row">
        <button @click=${() => (this.dialog = { kind: "details", name: d.local_name })}>
          ${t("devices.details")}
        </button>
        <span class="spacer"></span>
        <button
          class="danger"
          data-testid="remove-device"
          ${makes(request("DELETE", `/api/devices/${encodeURIComponent(d.local_name)}`))}
          @click=${() => (this.dialog = { kind: "remove", device: d })}
        >
          ${t("devices.remove")}
        </button>
      </div>
    </div>`;
  }

  // What a connected device's own state says is wrong (a camera whose --cell names no
  // robot): its link is fine, so the status chip alone would say all is well.
  private deviceSays(d: AddedDevice) {
    if (d.kind === "robot" || d.status !== "connected") return "";
    const error = (feed.states.get(d.local_name) as unknown as { error?: unknown } | undefined)?.error;
    if (typeof error !== "string" || !error) return "";
    return html`<div class="sub error" data-testid="device-error" role="status">${error}</div>`;
  }

  // Who else claimed this device's identity, and from where: shown, never followed silently.
  private claimNotice(d: AddedDevice) {
    const claim = d.address_claim;
    if (!claim) return "";
    const when = new Date(claim.seen * 1000).toLocaleTimeString();
    if (claim.followed) {
      return html`<div class="sub muted" data-testid="device-moved">
        ${t("devices.moved_from", { url: claim.url, time: when })}
      </div>`;
    }
    return html`<div class="sub warn-text" data-testid="device-claim" role="alert">
        ${t(claim.name ? "devices.claim_named" : "devices.claim", {
          time: when,
          name: d.local_name,
          claimed: claim.name,
          url: claim.url,
          address: d.url,
        })}
      </div>
      <div
        class="sub ${claim.proven ? "warn-text" : "muted"}"
        data-testid="device-claim-proof"
        data-proven=${claim.proven ? "yes" : "no"}
      >
        ${t(claim.proven ? "devices.claim_proven" : "devices.claim_unproven", {
          name: d.local_name,
        })}
      </div>
      <div class="row">
        <button
          data-testid="repoint-device"
          ${makes(request("PUT", `/api/devices/${encodeURIComponent(d.local_name)}/address`))}
          @click=${() => (this.dialog = { kind: "repoint", device: d, url: claim.url })}
        >
          ${t("devices.use_address", { url: claim.url })}
        </button>
      </div>`;
  }

  private renderDialog() {
    const dialog = this.dialog;
    if (!dialog) return "";
    const close = () => (this.dialog = null);
    switch (dialog.kind) {
      case "add":
        return html`<op-add-device-dialog
          .device=${dialog.device}
          url=${dialog.url}
          suggested=${this.suggestion(dialog.device?.kind ?? "robot")}
          @close=${close}
          @added=${close}
        ></op-add-device-dialog>`;
      case "details":
        return html`<op-device-details name=${dialog.name} @close=${close}></op-device-details>`;
      case "repoint":
        return html`<op-modal
          heading=${t("devices.repoint_heading", {
            name: dialog.device.local_name,
            url: dialog.url,
          })}
          @close=${close}
        >
          <p>
            ${withBold(
              t("devices.repoint_text", { url: dialog.url }),
              "name",
              dialog.device.local_name,
            )}
          </p>
          <div class="row">
            <span class="spacer"></span>
            <button @click=${close}>${t("devices.cancel")}</button>
            <button class="danger" data-testid="confirm-repoint" @click=${() => this.repoint(dialog.device, dialog.url)}
              ${makes(request("PUT", `/api/devices/${encodeURIComponent(dialog.device.local_name)}/address`))}>
              ${t("devices.halt_and_move")}
            </button>
          </div>
        </op-modal>`;
      case "remove":
        return html`<op-modal
          heading=${t("devices.remove_heading", { name: dialog.device.local_name })}
          @close=${close}
        >
          <p>${withBold(t("devices.remove_text"), "name", dialog.device.local_name)}</p>
          <div class="row">
            <span class="spacer"></span>
            <button @click=${close}>${t("devices.cancel")}</button>
            <button class="danger" data-testid="confirm-remove" @click=${() => this.removeDevice(dialog.device)}
              ${makes(request("DELETE", `/api/devices/${encodeURIComponent(dialog.device.local_name)}`))}>
              ${t("devices.remove")}
            </button>
          </div>
        </op-modal>`;
    }
  }

  private addByUrl(e: Event) {
    e.preventDefault();
    const url = this.url.trim();
    if (!/^https?:\/\/\S+$/.test(url)) {
      this.error = t("devices.address_invalid");
      return;
    }
    this.error = "";
    this.dialog = { kind: "add", device: null, url };
  }

  render() {
    const notAdded = feed.detected.filter((d) => !d.added_as).length;
    return html`
      ${this.error ? html`<p class="error" role="alert">${this.error}</p>` : ""}
      <section>
        <h2>${t("devices.added")}</h2>
        <div class="grid" data-testid="added-devices">
          ${feed.devices.length
            ? feed.devices.map((d) => this.addedCard(d))
            : html`<div class="card empty muted">
                ${t("devices.none_added")}
              </div>`}
        </div>
      </section>
      <section>
        <h2>
          ${t("devices.detected")}
          <span class="muted">${t("devices.not_added", { count: notAdded })}</span>
        </h2>
        <div class="grid" data-testid="detected-devices">
          ${feed.detected.length
            ? feed.detected.map((d) => this.detectedCard(d))
            : html`<div class="card empty muted">
                ${feed.online ? t("devices.searching") : t("devices.offline")}
              </div>`}
        </div>
      </section>
      <section>
        <h2>${t("devices.add_by_address")}</h2>
        <form class="by-url" @submit=${this.addByUrl}>
          <input
            placeholder=${t("devices.address_example")}
            aria-label=${t("devices.address_label")}
            inputmode="url"
            .value=${this.url}
            @input=${(e: InputEvent) => (this.url = (e.target as HTMLInputElement).value)}
          />
          <button type="submit" data-testid="add-by-address" ${makes(request("POST", "/api/devices"))}
            >${t("devices.add_ellipsis")}</button>
        </form>
      </section>
      ${this.renderDialog()}
    `;
  }
}

customElements.define("op-devices-panel", OpDevicesPanel);
