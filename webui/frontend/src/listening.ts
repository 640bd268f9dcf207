// An event listener for as long as a component is on the page: added as it is connected,
// removed as it leaves (one left behind keeps a removed component alive and re-rendering).

import type { ReactiveController, ReactiveControllerHost } from "lit";

export class Listening implements ReactiveController {
  constructor(
    host: ReactiveControllerHost,
    private readonly target: EventTarget,
    private readonly type: string,
    private readonly listener: EventListener,
  ) {
    host.addController(this);
  }

  hostConnected(): void {
    this.target.addEventListener(this.type, this.listener);
  }

  hostDisconnected(): void {
    this.target.removeEventListener(this.type, this.listener);
  }
}
