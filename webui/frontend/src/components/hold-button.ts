import { LitElement, css, html } from "lit";
import { tell } from "../rights";
import { shared } from "../styles";

// A hold-to-run button. Pointer events, so touch, pen and mouse behave the same. A finger or
// pen holds only once it has rested on the button for HOLD_STILL_MS without sliding: a swipe
// that starts on a button scrolls the page and moves nothing. The hold ends on release, on
// cancel (an incoming call, the page starting to scroll), when the finger slides off the
// button, and when the element goes away; the panel also ends holds when the tab hides.
const HOLD_STILL_MS = 150;
const SLOP_PX = 10;

let starting: OpHoldButton | null = null;

/** The button whose hold is starting, while its hold-start is handled: whoever acts on it
 * keeps it, to say there why the hold was refused. */
export function holdStarting(): OpHoldButton | null {
  return starting;
}

export class OpHoldButton extends LitElement {
  static properties = {
    label: { type: String },
    disabled: { type: Boolean },
    why: { type: String },
    active: { state: true },
  };
  declare label: string;
  declare disabled: boolean;
  /** Why it is disabled: said where the finger is when a disabled button is touched. */
  declare why: string;
  declare active: boolean;

  static styles = [
    shared,
    css`
      button {
        width: 100%;
        height: 100%;
        min-height: var(--hold-min-height, 64px);
        font-size: var(--hold-font-size, 26px);
        padding: 0 8px;
        touch-action: pan-y;
        -webkit-user-select: none;
        user-select: none;
        -webkit-touch-callout: none;
      }
      button.active {
        background: var(--accent);
        border-color: var(--accent);
        color: var(--on-accent);
      }
    `,
  ];

  constructor() {
    super();
    this.label = "";
    this.disabled = false;
    this.why = "";
    this.active = false;
    // On the element itself: the disabled button inside gets no events.
    this.addEventListener("pointerdown", (e) => {
      if (this.disabled && this.why && e.isPrimary) tell(this.why, this, e.clientX, e.clientY);
    });
  }

  private pending: { x: number; y: number; since: number; frame: number } | null = null;

  private start(e: PointerEvent) {
    if (this.disabled || !e.isPrimary || e.button > 0) return;
    const target = e.currentTarget as HTMLElement;
    // Touch captures the pointer implicitly; without this, sliding off would not end the hold.
    if (target.hasPointerCapture(e.pointerId)) target.releasePointerCapture(e.pointerId);
    if (e.pointerType === "mouse") {
      e.preventDefault();
      this.begin();
      return;
    }
    // Timed on animation frames: after a touch, Chrome holds timers back for about 100 ms.
    const pending = { x: e.clientX, y: e.clientY, since: performance.now(), frame: 0 };
    const wait = () => {
      if (this.pending !== pending) return;
      if (performance.now() - pending.since < HOLD_STILL_MS) {
        pending.frame = requestAnimationFrame(wait);
        return;
      }
      this.pending = null;
      this.begin();
    };
    this.pending = pending;
    pending.frame = requestAnimationFrame(wait);
  }

  private moved(e: PointerEvent) {
    const p = this.pending;
    if (p && Math.hypot(e.clientX - p.x, e.clientY - p.y) > SLOP_PX) this.cancelPending();
  }

  private cancelPending() {
    if (this.pending) cancelAnimationFrame(this.pending.frame);
    this.pending = null;
  }

  private begin() {
    this.active = true;
    starting = this;
    try {
      this.dispatchEvent(new CustomEvent("hold-start", { bubbles: true, composed: true }));
    } finally {
      starting = null;
    }
  }

  end() {
    this.cancelPending();
    if (!this.active) return;
    this.active = false;
    this.dispatchEvent(new CustomEvent("hold-end", { bubbles: true, composed: true }));
  }

  disconnectedCallback(): void {
    this.end();
    super.disconnectedCallback();
  }

  render() {
    return html`<button
      class=${this.active ? "active" : ""}
      ?disabled=${this.disabled}
      aria-pressed=${this.active ? "true" : "false"}
      @pointerdown=${this.start}
      @pointermove=${this.moved}
      @pointerup=${() => this.end()}
      @pointercancel=${() => this.end()}
      @pointerleave=${() => this.end()}
      @lostpointercapture=${() => this.end()}
      @contextmenu=${(e: Event) => e.preventDefault()}
      @keydown=${(e: KeyboardEvent) => {
        if ((e.key === " " || e.key === "Enter") && !e.repeat && !this.active) this.begin();
      }}
      @keyup=${() => this.end()}
      @blur=${() => this.end()}
    >
      <slot>${this.label}</slot>
    </button>`;
  }
}

customElements.define("op-hold-button", OpHoldButton);
