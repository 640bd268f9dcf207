import { LitElement, type PropertyDeclarations } from "lit";
import { errorText } from "../api";
import type { Overlay } from "./camera-view";

// What the Vision panel's steps share: a busy flag and the last error around each piece of
// work, and what a step lays over the live picture (an `overlay` event the panel keeps).
export class VisionStep extends LitElement {
  static properties: PropertyDeclarations = {
    busy: { state: true },
    error: { state: true },
  };
  declare busy: boolean;
  declare error: string;

  constructor() {
    super();
    this.busy = false;
    this.error = "";
  }

  protected async act(work: () => Promise<void>): Promise<void> {
    this.busy = true;
    this.error = "";
    try {
      await work();
    } catch (err) {
      this.error = errorText(err);
    } finally {
      this.busy = false;
    }
  }

  protected emitOverlay(overlay: Overlay): void {
    this.dispatchEvent(new CustomEvent("overlay", { detail: overlay, bubbles: true, composed: true }));
  }
}
