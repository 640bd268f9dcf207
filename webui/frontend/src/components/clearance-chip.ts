import { LitElement, css, html } from "lit";
import { client, ok, type Schemas } from "../api";
import { t } from "../i18n";
import { feed } from "../live";
import { shared } from "../styles";
import { roughLength } from "../units";

type Clearance = Schemas["Clearance"];

const POLL_MS = 500;
const NEAR = 0.05; // m: shown as a warning closer than this

// The robot's closest distance to anything else in the scene (obstacles, other robots),
// kept up to date while shown, so a technician jogging sees how near the arm is.
export class OpClearanceChip extends LitElement {
  static properties = { robot: { type: String }, clearance: { state: true } };
  declare robot: string;
  declare clearance: Clearance | null;
  private timer = 0;
  private busy = false;

  static styles = [
    shared,
    css`
      .chip {
        white-space: normal; /* a long pair of names wraps on a phone */
        border-radius: 14px;
      }
    `,
  ];

  constructor() {
    super();
    this.robot = "";
    this.clearance = null;
  }

  connectedCallback(): void {
    super.connectedCallback();
    this.timer = window.setInterval(() => void this.poll(), POLL_MS);
    void this.poll();
  }

  disconnectedCallback(): void {
    window.clearInterval(this.timer);
    super.disconnectedCallback();
  }

  private async poll(): Promise<void> {
    if (!this.robot || document.hidden || this.busy) return;
    if (!feed.online) {
      this.clearance = null; // nothing asked of a runtime that is not there
      return;
    }
    this.busy = true;
    try {
      this.clearance = await ok(client.GET("/api/motion/robots/{robot}/clearance",
        { params: { path: { robot: this.robot } } }));
    } catch {
      this.clearance = null;
    } finally {
      this.busy = false;
    }
  }

  render() {
    const c = this.clearance;
    if (!c) {
      return html`<span class="chip" data-testid="clearance">${t("jog.clearance.unknown")}</span>`;
    }
    const distance = roughLength; // whole millimetres show how near the arm is
    const names = { part: c.robot_part ?? "", other: c.other ?? "" };
    const text = c.distance == null
      ? t("jog.clearance.nothing_near")
      : c.distance < 0
        ? t("jog.clearance.inside", { ...names, distance: distance(-c.distance) })
        : t("jog.clearance.closest", { ...names, distance: distance(c.distance) });
    const near = c.distance != null && c.distance < NEAR;
    return html`<span class="chip ${near ? "bad" : ""}" data-testid="clearance">${text}</span>`;
  }
}

customElements.define("op-clearance-chip", OpClearanceChip);
