import { LitElement, css, html } from "lit";
import { shared } from "../styles";

// A hold-to-run button. Pointer events, so touch, pen and mouse behave the same. The hold
// ends on release, on cancel (an incoming call, a system gesture), when the finger slides off
// the button, and when the element goes away; the panel also ends holds when the tab hides.
export class OpHoldButton extends LitElement {
  static properties = { label: { type: String }, disabled: { type: Boolean }, active: { state: true } };
  declare label: string;
  declare disabled: boolean;
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
        touch-action: none;
        -webkit-user-select: none;
        user-select: none;
        -webkit-touch-callout: none;
      }
      button.active {
        background: var(--accent);
        border-color: var(--accent);
        color: #1a1204;
      }
    `,
  ];

  constructor() {
    super();
    this.label = "";
    this.disabled = false;
    this.active = false;
  }

  private start(e: PointerEvent) {
    if (this.disabled || !e.isPrimary || e.button > 0) return;
    e.preventDefault();
    const target = e.currentTarget as HTMLElement;
    // Touch captures the pointer implicitly; without this, sliding off would not end the hold.
    if (target.hasPointerCapture(e.pointerId)) target.releasePointerCapture(e.pointerId);
    this.active = true;
    this.dispatchEvent(new CustomEvent("hold-start", { bubbles: true, composed: true }));
  }

  end() {
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
      @pointerup=${() => this.end()}
      @pointercancel=${() => this.end()}
      @pointerleave=${() => this.end()}
      @lostpointercapture=${() => this.end()}
      @contextmenu=${(e: Event) => e.preventDefault()}
      @keydown=${(e: KeyboardEvent) => {
        if ((e.key === " " || e.key === "Enter") && !e.repeat && !this.active) {
          this.active = true;
          this.dispatchEvent(new CustomEvent("hold-start", { bubbles: true, composed: true }));
        }
      }}
      @keyup=${() => this.end()}
      @blur=${() => this.end()}
    >
      <slot>${this.label}</slot>
    </button>`;
  }
}

customElements.define("op-hold-button", OpHoldButton);
