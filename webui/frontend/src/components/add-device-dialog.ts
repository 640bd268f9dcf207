import { LitElement, css, html } from "lit";
import { client, errorText, ok } from "../api";
import { LOCAL_NAME, withBold } from "../format";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";
import type { DetectedDevice } from "../types";
import "./modal";

// Choose the local name a detected device (or a device at a URL) is added under.
export class OpAddDeviceDialog extends LitElement {
  static properties = {
    device: { attribute: false },
    url: { type: String },
    suggested: { type: String },
    localName: { state: true },
    pairing: { state: true },
    error: { state: true },
    busy: { state: true },
  };
  declare device: DetectedDevice | null;
  declare url: string;
  declare suggested: string;
  declare localName: string;
  declare pairing: string;
  declare error: string;
  declare busy: boolean;

  static styles = [
    shared,
    css`
      label {
        display: block;
        margin: 12px 0 6px;
        font-weight: 600;
      }
      .hint {
        font-size: 15px;
        margin-top: 6px;
      }
      .actions {
        display: flex;
        gap: 12px;
        justify-content: flex-end;
        margin-top: 20px;
      }
    `,
  ];

  constructor() {
    super();
    this.device = null;
    this.url = "";
    this.suggested = "";
    this.localName = "";
    this.pairing = "";
    this.error = "";
    this.busy = false;
  }

  willUpdate(changed: Map<string, unknown>): void {
    if (changed.has("suggested") && !this.localName) this.localName = this.suggested;
  }

  firstUpdated(): void {
    this.renderRoot.querySelector("input")?.focus();
  }

  private close() {
    this.dispatchEvent(new CustomEvent("close", { bubbles: true, composed: true }));
  }

  private async add(e: Event) {
    e.preventDefault();
    if (!LOCAL_NAME.test(this.localName) || this.busy) return;
    this.busy = true;
    this.error = "";
    try {
      const where = this.device ? { uuid: this.device.uuid } : { url: this.url };
      const pairing = this.pairing.trim();
      const body = { ...where, local_name: this.localName, ...(pairing ? { pairing } : {}) };
      const added = await ok(client.POST("/api/devices", { body }));
      this.dispatchEvent(new CustomEvent("added", { detail: added, bubbles: true, composed: true }));
    } catch (err) {
      this.error = errorText(err);
    } finally {
      this.busy = false;
    }
  }

  render() {
    const valid = LOCAL_NAME.test(this.localName);
    const what = this.device ? `${this.device.name} (${this.device.model})` : this.url;
    return html`<op-modal heading=${t("devices.add_heading")} data-testid="add-dialog">
      <p>${withBold(t("devices.add_text"), "device", what)}</p>
      <form @submit=${this.add}>
        <label for="local-name">${t("devices.local_name")}</label>
        <input
          id="local-name"
          data-testid="local-name"
          autocomplete="off"
          autocapitalize="none"
          spellcheck="false"
          .value=${this.localName}
          @input=${(e: InputEvent) => (this.localName = (e.target as HTMLInputElement).value.trim())}
        />
        <div class="hint ${valid ? "muted" : "error"}">
          ${t("devices.local_name_hint")}
        </div>
        <label for="pairing">${t("devices.pairing")}</label>
        <input
          id="pairing"
          data-testid="pairing-code"
          autocomplete="off"
          autocapitalize="none"
          spellcheck="false"
          .value=${this.pairing}
          @input=${(e: InputEvent) => (this.pairing = (e.target as HTMLInputElement).value)}
        />
        <div class="hint muted">${t("devices.pairing_hint")}</div>
        ${this.error ? html`<p class="error" role="alert">${this.error}</p>` : ""}
        <div class="actions">
          <button type="button" @click=${this.close}>${t("devices.cancel")}</button>
          <button class="primary" type="submit" data-testid="confirm-add" ?disabled=${!valid || this.busy}
            ${makes(request("POST", "/api/devices"))}>
            ${this.busy ? t("devices.adding") : t("devices.add")}
          </button>
        </div>
      </form>
    </op-modal>`;
  }
}

customElements.define("op-add-device-dialog", OpAddDeviceDialog);
