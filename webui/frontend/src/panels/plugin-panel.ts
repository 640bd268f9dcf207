// A plugin's panel: its module imported on first show, then its element, given the PendantHost.
import { LitElement, html } from "lit";
import { t } from "../i18n";
import { type PanelInfo, hostFor, plugins } from "../plugins";
import { shared } from "../styles";

export class OpPluginPanel extends LitElement {
  static properties = { panel: { attribute: false }, failed: { state: true } };
  declare panel: PanelInfo;
  declare failed: string;
  static styles = [shared];

  constructor() {
    super();
    this.failed = "";
  }

  protected updated(changed: Map<string, unknown>): void {
    if (changed.has("panel")) void this.mount();
  }

  private async mount(): Promise<void> {
    const panel = this.panel;
    this.failed = "";
    try {
      await plugins.module(panel);
      await customElements.whenDefined(panel.element);
    } catch (err) {
      this.failed = err instanceof Error ? err.message : String(err);
      return;
    }
    if (this.panel !== panel) return;
    const host = this.renderRoot.querySelector(".mount");
    if (!host) return;
    const element = document.createElement(panel.element) as HTMLElement & { pendant?: unknown };
    element.pendant = hostFor(panel);
    host.replaceChildren(element);
  }

  render() {
    return html`${this.failed
        ? html`<p class="error" role="alert" data-testid="plugin-panel-error">
            ${t("app.plugin_panel_failed", { plugin: this.panel.plugin })}
            <span translate="no">${this.failed}</span>
          </p>`
        : ""}
      <div class="mount"></div>`;
  }
}

customElements.define("op-plugin-panel", OpPluginPanel);
