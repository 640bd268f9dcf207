import { LitElement, css, html } from "lit";
import { ApiError, api, errorText } from "./api";
import { control } from "./control";
import { FocusController, focus } from "./focus";
import { linkLabel, modeLabel } from "./format";
import { t } from "./i18n";
import { FeedController, feed } from "./live";
import { shared } from "./styles";
import type { AddedDevice, RobotState } from "./types";

// Always on screen, above every panel and never scrolled away: the runtime link, the robots
// with the one in focus (tap another to focus it), its mode and faults, the speed override,
// and STOP.
export class OpStatusBar extends LitElement {
  static properties = { notice: { state: true } };
  declare notice: string;
  private sending = 0;
  private shownRobot = "";

  static styles = [
    shared,
    css`
      :host {
        display: flex;
        align-items: center;
        gap: 10px;
        flex-wrap: wrap;
        padding: 8px 12px;
        min-height: 72px;
        background: var(--bar-bg);
        border-bottom: 1px solid var(--line);
      }
      .brand {
        font-weight: 800;
        font-size: 20px;
        letter-spacing: 0.02em;
      }
      .brand span {
        color: var(--accent);
      }
      .robots {
        display: flex;
        gap: 8px;
        flex-wrap: wrap;
        flex: 1 1 260px;
        min-width: 0;
      }
      button.robot {
        display: flex;
        align-items: center;
        gap: 8px;
        padding: 4px 12px;
        min-height: 52px;
        font-size: 16px;
        background: var(--panel);
      }
      button.robot[aria-pressed="true"] {
        border-color: var(--accent);
        background: var(--raised);
        box-shadow: inset 0 -4px 0 var(--accent);
      }
      .choose {
        color: var(--warn);
        font-weight: 700;
        align-self: center;
      }
      .speed {
        display: flex;
        align-items: center;
        gap: 8px;
        flex: 0 1 260px;
        font-size: 16px;
      }
      .speed input {
        flex: 1;
        min-width: 90px;
        min-height: 48px;
        padding: 0;
        border: none;
        background: transparent;
        accent-color: var(--accent);
      }
      .speed strong {
        min-width: 3.2em;
        text-align: right;
        font-variant-numeric: tabular-nums;
      }
      .stop {
        background: #c62828;
        border-color: #ff8a80;
        color: white;
        font-size: 22px;
        font-weight: 800;
        min-width: 120px;
        min-height: 60px;
      }
      .offline {
        background: var(--bad);
        color: white;
        font-weight: 700;
        padding: 8px 14px;
        border-radius: 10px;
      }
      @media (max-width: 700px) {
        :host {
          gap: 6px;
          padding: 6px 8px;
        }
        /* Two rows on a phone: the robots and STOP, then the speed override. */
        .brand,
        .link-ok {
          display: none;
        }
        .robots {
          flex: 1 1 0;
        }
        .stop {
          order: 1;
          min-width: 96px;
        }
        .speed,
        .offline,
        .notice {
          order: 2;
          flex: 1 1 100%;
        }
      }
    `,
  ];

  constructor() {
    super();
    new FeedController(this);
    new FocusController(this);
    this.notice = "";
  }

  protected willUpdate(): void {
    // A robot newly in focus brings its own speed override to the slider.
    const robot = focus.robot;
    const ratio = feed.states.get(robot)?.speed_ratio;
    if (robot !== this.shownRobot && ratio !== undefined) {
      this.shownRobot = robot;
      if (Math.round(ratio * 100) !== focus.speed) focus.setSpeed(ratio * 100);
    }
  }

  /** The override goes to the robot in focus: a running program slows or speeds up on its
   * path. Lowering it is always allowed; raising it needs control of the robot. */
  private setSpeed(percent: number): void {
    focus.setSpeed(percent);
    window.clearTimeout(this.sending);
    this.sending = window.setTimeout(() => void this.sendSpeed(), 150);
  }

  private async sendSpeed(): Promise<void> {
    const robot = focus.robot;
    if (!robot) return;
    const token = control.token(robot);
    try {
      await api("PUT", `/api/jog/robots/${encodeURIComponent(robot)}/speed`,
        { ratio: focus.speed / 100 }, token ? { "X-Lease-Token": token } : {});
      this.notice = "";
    } catch (err) {
      const ratio = feed.states.get(robot)?.speed_ratio;
      if (ratio !== undefined) focus.setSpeed(ratio * 100);
      this.notice = err instanceof ApiError && err.code.startsWith("lease")
        ? t("app.raise_needs_control") : errorText(err);
    }
  }

  /** Stop always wins: every robot halts, every program stops and every other device that
   * can stop (a plugin's device) is stopped, whatever is in focus. */
  private async stop(): Promise<void> {
    window.dispatchEvent(new Event("op-stop")); // panels let go of what they hold
    const robots = feed.robots().map((r) => r.local_name);
    await Promise.allSettled([
      ...robots.map((r) => api("POST", `/api/jog/robots/${encodeURIComponent(r)}/halt`)),
      api("POST", "/api/programs/_stop"),
      api("POST", "/api/devices/_stop"),
    ]);
  }

  private robotChip(device: AddedDevice, state: RobotState | undefined, inFocus: boolean) {
    const link = device.status === "connected" ? "ok" : device.status === "connecting" ? "warn" : "bad";
    const live = feed.online && device.status === "connected";
    let badge = html``;
    if (live && state?.flags.estop) badge = html`<span class="chip bad">${t("app.estop")}</span>`;
    else if (live && state?.flags.protective_stop)
      badge = html`<span class="chip bad">${t("app.protective_stop")}</span>`;
    else if (live && state?.flags.error)
      badge = html`<span class="chip bad" title=${state.error_message}>${t("app.error")}</span>`;
    else if (live && state && !state.flags.enabled)
      badge = html`<span class="chip">${t("app.disabled")}</span>`;
    return html`<button class="robot" data-testid="status-robot" data-name=${device.local_name}
      aria-pressed=${inFocus ? "true" : "false"}
      title=${inFocus ? t("app.in_focus") : t("app.focus_robot", { name: device.local_name })}
      @click=${() => focus.choose(device.local_name)}>
      <span class="dot ${feed.online ? link : "bad"}" title=${linkLabel(device.status)}></span>
      <strong>${device.local_name}</strong>
      ${live && state
        ? html`<span class="muted">${modeLabel(state.operational_mode)}</span>`
        : html`<span class="muted"
            >${feed.online ? linkLabel(device.status) : t("app.link.unknown")}</span
          >`}
      ${badge}
    </button>`;
  }

  render() {
    const robots = feed.robots();
    const inFocus = focus.robot;
    return html`
      <div class="brand" translate="no">Open<span>Pendant</span></div>
      <div class="robots" role="group" aria-label=${t("app.robot_in_focus")}>
        ${robots.length === 0 && feed.online
          ? html`<span class="muted">${t("app.no_robot")}</span>`
          : robots.map((d) =>
              this.robotChip(d, feed.states.get(d.local_name), d.local_name === inFocus),
            )}
        ${robots.length > 1 && !inFocus
          ? html`<span class="choose" data-testid="focus-missing" role="alert">
              ${t("app.choose_robot")}</span>`
          : ""}
      </div>
      <label class="speed" title=${t("app.speed_title")}>
        <span>${t("app.speed")}</span>
        <input type="range" min="1" max="100" .value=${String(focus.speed)}
          data-testid="speed" aria-label=${t("app.speed_override")}
          @input=${(e: Event) => this.setSpeed(Number((e.target as HTMLInputElement).value))} />
        <strong data-testid="speed-value">${focus.speed} %</strong>
      </label>
      ${this.notice ? html`<span class="chip warn notice" role="alert">${this.notice}</span>` : ""}
      ${feed.online
        ? html`<span class="chip ok link-ok" data-testid="runtime-link"
            >${t("app.runtime_connected")}</span
          >`
        : html`<span class="offline" data-testid="runtime-link" role="alert"
            >${t("app.runtime_offline")}</span
          >`}
      <button class="stop" data-testid="safety-stop"
        title=${t("app.stop_title")}
        @click=${() => this.stop()}>${t("app.stop")}</button>
    `;
  }
}

customElements.define("op-status-bar", OpStatusBar);
