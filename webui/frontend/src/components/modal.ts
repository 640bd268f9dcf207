import { LitElement, css, html } from "lit";
import { Listening } from "../listening";
import { shared } from "../styles";

// A modal sheet: large, centred on a tablet, full-width on a phone. Escape or the backdrop closes it.
export class OpModal extends LitElement {
  static properties = { heading: { type: String } };
  declare heading: string;

  static styles = [
    shared,
    css`
      .backdrop {
        position: fixed;
        inset: 0;
        background: var(--scrim);
        display: flex;
        align-items: center;
        justify-content: center;
        z-index: 100;
        padding: 16px;
      }
      .sheet {
        background: var(--panel);
        border: 1px solid var(--line);
        border-radius: 16px;
        padding: 20px;
        width: min(560px, 100%);
        max-height: 90vh;
        overflow: auto;
      }
      h2 {
        margin-top: 0;
      }
    `,
  ];

  constructor() {
    super();
    new Listening(this, window, "keydown", this.onKey as EventListener);
    this.heading = "";
  }

  private onKey = (e: KeyboardEvent) => {
    if (e.key === "Escape") this.close();
  };


  private close() {
    this.dispatchEvent(new CustomEvent("close", { bubbles: true, composed: true }));
  }

  render() {
    return html`<div
      class="backdrop"
      @click=${(e: Event) => e.target === e.currentTarget && this.close()}
    >
      <div class="sheet" role="dialog" aria-modal="true" aria-label=${this.heading}>
        <h2>${this.heading}</h2>
        <slot></slot>
      </div>
    </div>`;
  }
}

customElements.define("op-modal", OpModal);
