import { LitElement, css, html } from "lit";
import { t } from "../i18n";
import { worded } from "../i18n/words";
import type { JogStatus } from "../jog-socket";
import { shared } from "../styles";
import type { InputState } from "../types";

// The Jog panel's banner over the keys: whether jogging can start (the link, control,
// enabled), and what the key, Move to or 3D mouse held is doing (moving, held back and why,
// halted, refused, arrived, stopped).
export class OpJogStatus extends LitElement {
  static properties = {
    online: { type: Boolean },
    status: { attribute: false },
    mine: { type: Boolean },
    ready: { type: Boolean },
    movingTo: { type: String },
    freedrive: { type: Boolean },
    mouse: { attribute: false },
  };
  declare online: boolean; // the jog socket is open
  declare status: JogStatus | null; // of the last press
  declare mine: boolean; // this tab has control
  declare ready: boolean; // the robot is ready to move
  declare movingTo: string; // the waypoint a held Move to is going to
  declare freedrive: boolean; // the press is Freedrive: the arm is moved by hand
  declare mouse: InputState | null; // the 3D mouse the last press was, if it was one

  static styles = [
    shared,
    css`
      :host {
        display: block;
      }
      .deadman {
        display: block;
        white-space: normal; /* a long halt reason wraps, never runs off the screen */
        overflow-wrap: anywhere;
        padding: 10px 14px;
        border-radius: 10px;
        margin-bottom: 10px;
        font-weight: 600;
      }
    `,
  ];

  constructor() {
    super();
    this.online = false;
    this.status = null;
    this.mine = false;
    this.ready = false;
    this.movingTo = "";
    this.freedrive = false;
    this.mouse = null;
  }

  render() {
    const s = this.status;
    if (!this.online) {
      return html`<div class="deadman chip bad" data-testid="deadman">${t("jog.link_down")}</div>`;
    }
    if (!s) {
      const ready = !this.mine ? t("jog.control.take_to_jog")
        : !this.ready ? t("jog.enable_to_jog")
        : t("jog.ready");
      return html`<div class="deadman chip" data-testid="deadman">${ready}</div>`;
    }
    const cls = s.state === "moving" ? "ok" : s.state === "held" ? "warn"
      : s.state === "halted" || s.state === "refused" ? "bad" : "";
    const mouse = this.mouse;
    if (mouse && s.state === "moving") {
      const atRest = !mouse.axes.some((a) => a !== 0);
      return html`<div class="deadman chip ${atRest ? "" : "ok"}" data-testid="deadman">
        ${atRest ? t("jog.mouse.at_rest") : t("jog.mouse.moving")}</div>`;
    }
    // The 3D mouse still on, driving nothing: gone (the robot halted), or not yet let go.
    if (s.state === "held" && (s.reason === "mouse_away" || s.reason === "mouse_not_at_rest")) {
      const away = s.reason === "mouse_away";
      return html`<div class="deadman chip ${away ? "bad" : "warn"}" data-testid="deadman">
        ${away ? t("jog.mouse.away") : t("jog.mouse.not_at_rest")}</div>`;
    }
    const text = s.state === "moving" && this.freedrive ? t("jog.freedrive_on")
      : s.state === "moving" && this.movingTo
      ? t("jog.moving_to", { name: this.movingTo })
      : s.state === "moving" ? t("jog.moving")
      : s.state === "held"
      ? t("jog.not_moving", { reason: s.message ? worded(s.message, s.words) : t("jog.held_back") })
      : s.state === "halted"
      ? t("jog.halted", { reason: s.words && s.message ? worded(s.message, s.words) : s.reason ?? "" })
      : s.state === "refused"
      ? t("jog.refused", { reason: s.message ? worded(s.message, s.words) : s.reason ?? "" })
      : s.state === "done" ? t("jog.arrived") : t("jog.stopped");
    return html`<div class="deadman chip ${cls}" data-testid="deadman">${text}</div>`;
  }
}

customElements.define("op-jog-status", OpJogStatus);
