import { LitElement, css, html } from "lit";
import { leaseRequest } from "../control";
import { t } from "../i18n";
import { makes, request } from "../rights";
import { shared } from "../styles";

export type PowerCommand = "enable" | "disable" | "reset_errors";

// The head of the Jog panel: the robot in focus, taking and releasing control, who has it,
// and powering the robot (enable, disable, reset an error). Emits control-toggle and
// power {command}; the panel acts.
export class OpJogHeader extends LitElement {
  static properties = {
    robot: { type: String },
    mine: { type: Boolean },
    holder: { type: String },
    controlledBy: { type: String },
    enabled: { type: Boolean },
    error: { type: Boolean },
    canPower: { type: Boolean },
    powersOn: { type: Boolean },
    unlocks: { type: Boolean },
  };
  declare robot: string;
  declare mine: boolean; // this tab has control
  declare holder: string; // this tab's name as others see it, while it has control
  declare controlledBy: string; // who has control, "" nobody
  declare enabled: boolean;
  declare error: boolean;
  declare canPower: boolean;
  declare powersOn: boolean; // Enable also powers the arm on and releases its brakes (a UR)
  declare unlocks: boolean; // Reset error now also unlocks a protective stop (a UR)

  static styles = [
    shared,
    css`
      :host {
        display: flex;
        gap: 10px;
        flex-wrap: wrap;
        align-items: center;
        margin-bottom: 12px;
      }
    `,
  ];

  constructor() {
    super();
    this.robot = "";
    this.mine = false;
    this.holder = "";
    this.controlledBy = "";
    this.enabled = false;
    this.error = false;
    this.canPower = false;
    this.powersOn = false;
    this.unlocks = false;
  }

  private power(command: PowerCommand): void {
    this.dispatchEvent(new CustomEvent("power", { detail: { command } }));
  }

  private powers(command: PowerCommand) {
    return makes(request("POST", `/api/jog/robots/${encodeURIComponent(this.robot)}/${command}`));
  }

  render() {
    const mine = this.mine;
    const controlledBy = this.controlledBy;
    return html`<h2 style="margin:0" data-testid="jog-robot">${this.robot}</h2>
      <button data-testid="control" class=${mine ? "" : "primary"}
        ${makes(leaseRequest(this.robot, mine))}
        @click=${() => this.dispatchEvent(new CustomEvent("control-toggle"))}>
        ${mine ? t("jog.control.release") : t("jog.control.take")}</button>
      <span class="chip ${mine ? "ok" : controlledBy ? "warn" : ""}" data-testid="lease">
        ${mine ? t("jog.control.yours", { holder: this.holder })
          : controlledBy ? t("jog.control.controlled_by", { holder: controlledBy })
          : t("jog.control.nobody")}</span>
      ${this.enabled
        ? html`<button data-testid="disable" ?disabled=${!this.canPower} ${this.powers("disable")}
            @click=${() => this.power("disable")}>${t("jog.disable")}</button>`
        : html`<button data-testid="enable" ?disabled=${!this.canPower} ${this.powers("enable")}
            @click=${() => this.power("enable")}>
            ${t(this.powersOn ? "jog.power_on_enable" : "jog.enable")}</button>`}
      ${this.error
        ? html`<button data-testid="reset-error" ?disabled=${!this.canPower}
            ${this.powers("reset_errors")}
            @click=${() => this.power("reset_errors")}>
            ${t(this.unlocks ? "jog.unlock_reset" : "jog.reset_error")}</button>`
        : ""}`;
  }
}

customElements.define("op-jog-header", OpJogHeader);
