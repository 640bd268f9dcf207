import { LitElement, css, html } from "lit";
import { ApiError, client, errorText, ok } from "./api";
import { control } from "./control";
import { FocusController, focus } from "./focus";
import { linkLabel } from "./format";
import { t } from "./i18n";
import { FeedController, feed } from "./live";
import { makes, request } from "./rights";
import { session } from "./session";
import { chipState } from "./robot-chip";
import { shared } from "./styles";
import type { AddedDevice, RobotState } from "./types";

/** The robots that have been in focus on this page: each is slowed to the first speed once. */
const focusedHere = new Set<string>();
let firstSpeedAsked: Promise<number | null> | null = null;

/** The site's first speed override (a ratio), from the jog service; null if unknown. */
function firstSpeed(): Promise<number | null> {
  firstSpeedAsked ??= ok(client.GET("/api/jog/settings"))
    .then((settings): number | null => settings.first_speed_ratio)
    .catch(() => {
      firstSpeedAsked = null; // asked again next time
      return null;
    });
  return firstSpeedAsked;
}

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
      /* The link's or the fault's colour over the whole chip, in focus or not. */
      button.robot.bad {
        background: var(--bad-bg);
        color: var(--bad-fg);
        border-color: var(--bad);
      }
      button.robot.warn {
        background: var(--warn-bg);
        color: var(--warn-fg);
        border-color: var(--warn);
      }
      button.robot.bad[aria-pressed="true"],
      button.robot.warn[aria-pressed="true"] {
        border-color: var(--accent);
      }
      button.robot .state {
        white-space: nowrap;
      }
      button.robot.ok .state,
      button.robot.idle .state {
        color: var(--muted);
      }
      button.robot.bad .state,
      button.robot.warn .state {
        font-weight: 800;
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
        /* Two rows on a phone, under 15 % of its height: the robots (scrolling sideways when
           there are many) and STOP, then the speed override. */
        :host {
          gap: 4px 6px;
          padding: 4px 6px;
          min-height: 0;
        }
        .brand,
        .link-ok {
          display: none;
        }
        .robots {
          flex: 1 1 0;
          flex-wrap: nowrap;
          overflow-x: auto;
          overscroll-behavior: contain;
          scrollbar-width: none;
          gap: 6px;
        }
        button.robot {
          flex: none;
          min-height: 48px;
          padding: 2px 10px;
          gap: 6px;
          font-size: 15px;
        }
        .choose {
          white-space: nowrap;
        }
        .stop {
          order: 1;
          min-width: 88px;
          min-height: 52px;
          padding: 0 12px;
          font-size: 20px;
        }
        .speed,
        .offline,
        .notice {
          order: 2;
          flex: 1 1 100%;
        }
        .speed input {
          min-height: 48px;
        }
        .offline {
          padding: 4px 10px;
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
    // A robot newly in focus brings its own speed override to the slider; the first time
    // it comes into focus on this pendant, an override above the site's first speed is
    // lowered to it (lowering needs nobody's control), so nobody's first hold here runs at
    // the speed someone else left.
    const robot = focus.robot;
    const ratio = feed.states.get(robot)?.speed_ratio;
    if (robot !== this.shownRobot && ratio !== undefined) {
      this.shownRobot = robot;
      if (Math.round(ratio * 100) !== focus.speed) focus.setSpeed(ratio * 100);
      // A viewer may not set it (nor jog): the slider shows the robot's own.
      const speed = `/api/jog/robots/${encodeURIComponent(robot)}/speed`;
      if (!focusedHere.has(robot) && session.may("PUT", speed)) {
        focusedHere.add(robot);
        void firstSpeed().then((first) => {
          if (focus.robot === robot && first !== null && focus.speed > Math.round(first * 100)) {
            this.setSpeed(Math.round(first * 100));
          }
        });
      }
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
      await ok(client.PUT("/api/jog/robots/{robot}/speed", {
        params: { path: { robot }, header: { "X-Lease-Token": token } },
        body: { ratio: focus.speed / 100 },
      }));
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
      ...robots.map((r) => ok(client.POST("/api/jog/robots/{robot}/halt",
        { params: { path: { robot: r } } }))),
      ok(client.POST("/api/programs/_stop")),
      ok(client.POST("/api/devices/_stop")),
    ]);
  }

  private robotChip(device: AddedDevice, state: RobotState | undefined, inFocus: boolean) {
    const chip = chipState(device, state, feed.online);
    return html`<button class="robot ${chip.level}" data-testid="status-robot"
      data-name=${device.local_name} data-level=${chip.level}
      aria-pressed=${inFocus ? "true" : "false"}
      title=${inFocus ? t("app.in_focus") : t("app.focus_robot", { name: device.local_name })}
      @click=${() => focus.choose(device.local_name)}>
      <span class="dot ${chip.level === "idle" ? "ok" : chip.level}"
        title=${feed.online ? linkLabel(device.status) : ""}></span>
      <strong>${device.local_name}</strong>
      <span class="state" data-testid="status-robot-state" title=${chip.detail}
        >${chip.text}</span>
      ${chip.disabled ? html`<span class="chip">${t("app.disabled")}</span>` : ""}
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
          ${makes(...(inFocus
            ? [request("PUT", `/api/jog/robots/${encodeURIComponent(inFocus)}/speed`)] : []))}
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
        ${makes(
          ...robots.map((r) => request("POST", `/api/jog/robots/${encodeURIComponent(r.local_name)}/halt`)),
          request("POST", "/api/programs/_stop"),
          request("POST", "/api/devices/_stop"),
        )}
        title=${t("app.stop_title")}
        @click=${() => this.stop()}>${t("app.stop")}</button>
    `;
  }
}

customElements.define("op-status-bar", OpStatusBar);
